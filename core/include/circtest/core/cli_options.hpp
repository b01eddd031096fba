#pragma once
// Boost.Program_options' errors in circtest's words, for every program that parses options
// with it (header only: core itself does not link Boost.Program_options).
#include <boost/program_options/errors.hpp>
#include <boost/program_options/options_description.hpp>
#include <string>
#include <vector>

#include "circtest/core/cli.hpp"
#include "circtest/core/error.hpp"

namespace circtest {

// The UsageError for an option parse failure: an unknown option with the closest known one
// ("unknown option --radus; did you mean --radius?"), any other error in Boost's words.
inline UsageError option_usage_error(const boost::program_options::error& e,
                                     const boost::program_options::options_description& desc) {
  if (const auto* unknown = dynamic_cast<const boost::program_options::unknown_option*>(&e)) {
    std::vector<std::string> known;
    for (const auto& o : desc.options()) {
      if (!o->long_name().empty()) known.push_back("--" + o->long_name());
    }
    return UsageError(unknown_option_message(unknown->get_option_name(), known));
  }
  return UsageError(e.what());
}

}  // namespace circtest
