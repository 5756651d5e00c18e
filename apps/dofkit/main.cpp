// dofkit command-line tool: subcommand dispatch and error reporting.
#include <cstdio>
#include <exception>
#include <iostream>
#include <new>
#include <stdexcept>

#include "commands.hpp"
#include "dofkit/error.hpp"
#include "io/atomic_write.hpp"

int main(int argc, char** argv) {
  // SIGINT / SIGTERM / SIGHUP during a write remove the temporary file (atomic_write.hpp).
  dofkit::io::install_signal_cleanup();
  CLI::App app{"dofkit — camera depth of field (lens blur) from a colour image and a depth map"};
  app.require_subcommand(1);
  app.set_help_all_flag("--help-all", "print help for every subcommand");
  app.set_version_flag("--version", "dofkit " DOFKIT_VERSION, "print the version and exit");
  dofkit::cli::add_render_command(app);
  dofkit::cli::add_methods_command(app);
  dofkit::cli::add_demo_command(app);
  dofkit::cli::add_scene_command(app);
  dofkit::cli::add_compare_command(app);
  dofkit::cli::add_quality_command(app);
  dofkit::cli::add_bench_command(app);
  dofkit::cli::add_ssao_command(app);
  dofkit::cli::add_light_command(app);
  dofkit::cli::add_pipeline_command(app);
  dofkit::cli::add_view_command(app);
  // Every error is one line on stderr (dofkit::Error escapes control characters itself; the
  // others are escaped here) and an exit code: usage 2, bad input 3, internal 1.
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    std::cerr << "dofkit: " << dofkit::one_line(e.what()) << " (see dofkit --help)\n";
    return 2;
  } catch (const dofkit::Error& e) {
    std::cerr << "dofkit: error: " << e.what() << "\n";
    return e.exit_code();
  } catch (const std::bad_alloc&) {
    // An allocation no estimate foresaw (the commands check --max-memory first and name what
    // they were doing where they can): the request was too large for this machine.
    std::cerr << "dofkit: error: out of memory (the request is too large for this machine; see --max-memory)\n";
    return 3;
  } catch (const std::length_error&) {
    std::cerr << "dofkit: error: out of memory (a buffer beyond the largest possible size)\n";
    return 3;
  } catch (const std::exception& e) {
    std::cerr << "dofkit: internal error: " << dofkit::one_line(e.what()) << "\n";
    return 1;
  }
  return 0;
}
