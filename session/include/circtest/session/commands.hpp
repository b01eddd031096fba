#pragma once
// The `circtest` commands as the front end calls them: each takes its request and the console
// and returns the exit code; errors are circtest::Error.
#include <string>

#include "circtest/session/console.hpp"
#include "circtest/session/install.hpp"
#include "circtest/session/run.hpp"

namespace circtest::session {

// Prints the diff and the channels, asks, applies; says to restart LinuxCNC.
int install_command(const InstallRequest& request, const Console& console);
// Undoes the install; says to restart LinuxCNC.
int uninstall_command(const std::string& ini_path, const Console& console);

}  // namespace circtest::session
