#include "circtest/core/sha256.hpp"

#include <fmt/format.h>
#include <openssl/evp.h>

#include "circtest/core/atomic_file.hpp"
#include "circtest/core/error.hpp"

namespace circtest {

std::string sha256_hex(std::string_view data) {
  unsigned char digest[EVP_MAX_MD_SIZE];
  unsigned int size = 0;
  if (EVP_Digest(data.data(), data.size(), digest, &size, EVP_sha256(), nullptr) != 1) {
    throw Error(ExitCode::internal, "SHA-256 failed");
  }
  std::string hex;
  for (unsigned int i = 0; i < size; ++i) hex += fmt::format("{:02x}", digest[i]);
  return hex;
}

std::string sha256_of_file(const std::string& path) {
  return sha256_hex(read_file(path));
}

}  // namespace circtest
