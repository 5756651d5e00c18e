// `dofkit render ARGS` run in-process through the command the binary registers, errors mapped
// to exit codes as main.cpp maps them (shared by the render CLI tests).
#pragma once
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "commands.hpp"
#include "dofkit/error.hpp"

namespace dofkit::test {

struct CliResult {
  int code = -1;
  std::string message;  // the one-line error (what main prints after "dofkit: error: ")
  std::string out;      // stdout
  std::string err;      // stderr (notes and warnings)
};

inline CliResult run_render(std::vector<std::string> args) {
  CLI::App app{"dofkit"};
  app.require_subcommand(1);
  cli::add_render_command(app);
  args.insert(args.begin(), "render");
  std::vector<std::string> rev(args.rbegin(), args.rend());  // CLI11 consumes a reversed vector
  CliResult r;
  ::testing::internal::CaptureStdout();
  ::testing::internal::CaptureStderr();
  try {
    app.parse(rev);
    r.code = 0;
  } catch (const CLI::ParseError& e) {
    r.code = e.get_exit_code() == 0 ? 0 : 2;
    r.message = e.what();
  } catch (const Error& e) {
    r.code = e.exit_code();
    r.message = e.what();
  } catch (const std::exception& e) {
    r.code = 1;
    r.message = e.what();
  }
  r.err = ::testing::internal::GetCapturedStderr();
  r.out = ::testing::internal::GetCapturedStdout();
  return r;
}

}  // namespace dofkit::test
