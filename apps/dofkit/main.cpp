// dofkit command-line tool: subcommand dispatch and error reporting.
#include <cstdio>
#include <exception>
#include <iostream>

#include "commands.hpp"
#include "dofkit/error.hpp"

int main(int argc, char** argv) {
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
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    std::cerr << "dofkit: " << e.what() << " (see dofkit --help)\n";
    return 2;
  } catch (const dofkit::Error& e) {
    std::cerr << "dofkit: error: " << e.what() << "\n";
    return e.exit_code();
  } catch (const std::bad_alloc&) {
    std::cerr << "dofkit: error: out of memory\n";
    return 1;
  } catch (const std::exception& e) {
    std::cerr << "dofkit: internal error: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
