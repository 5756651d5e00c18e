// libFuzzer target for the command line (issue 37): structured sequences of flags and values
// for `dofkit render`, `compare` and `methods`, parsed and run as main() runs them, against
// small files in a private folder (which is also the working directory: a value the fuzzer
// spells itself holds no '/', so nothing is written outside it).
//
// Input: byte 0 picks the subcommand and whether a working base command line comes first
// (so that the flags the fuzzer adds reach the render, not only the parser); then pairs of
// bytes: a flag of that subcommand, and a value from the dictionary of that flag's kind
// (input paths — good files, a fifo, a folder, a symlink loop, missing ones, frame patterns —
// output paths, hostile numbers, lists, words) or, for a high value byte, a string spelled by
// the following bytes.
// Bugs: an exception that is not CLI11's or a one-line usage / bad-input dofkit::Error, an
// internal error, a temporary file left behind, an input file changed.
#include <CLI/CLI.hpp>
#include <dirent.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "commands.hpp"
#include "dofkit/image.hpp"
#include "fuzz_common.hpp"
#include "io/layers_io.hpp"

using namespace dofkit;
namespace fs = std::filesystem;

namespace {

std::string g_dir;                                  // the private folder (the working directory)
std::set<std::string> g_inputs;                     // the files made at start-up
std::vector<std::pair<std::string, long>> g_sizes;  // and their sizes

enum Kind { in_path, out_path, number, list, word, flag_only };
struct Flag {
  const char* name;
  Kind kind;
};

const std::vector<Flag> kRender = {{"--color", in_path},
                                   {"--depth", in_path},
                                   {"--layers", in_path},
                                   {"--mask", in_path},
                                   {"--mask-depth", in_path},
                                   {"--output", out_path},
                                   {"--output-coc", out_path},
                                   {"--debug-output", out_path},
                                   {"--debug-view", word},
                                   {"--method", word},
                                   {"--set", word},
                                   {"--threads", number},
                                   {"--focus", number},
                                   {"--focus-at", list},
                                   {"--f-number", number},
                                   {"--focal-length", number},
                                   {"--sensor-width", number},
                                   {"--blur-at-infinity", number},
                                   {"--planes", list},
                                   {"--planes-ramp", word},
                                   {"--near-radius", number},
                                   {"--far-radius", number},
                                   {"--starcraft", list},
                                   {"--near-far", list},
                                   {"--max-radius", number},
                                   {"--max-coc", number},
                                   {"--reference-width", number},
                                   {"--depth-kind", word},
                                   {"--fov-deg", number},
                                   {"--disparity-scale", number},
                                   {"--clip", list},
                                   {"--invalid-depth", word},
                                   {"--max-pixels", number},
                                   {"--max-memory", number},
                                   {"--max-work", number},
                                   {"--max-layers", number},
                                   {"--bits", number},
                                   {"--compression", word},
                                   {"--png-level", number},
                                   {"--frames", word},
                                   {"--help", flag_only}};
const std::vector<Flag> kCompare = {{"REF", in_path},        {"TEST", in_path},     {"--depth", in_path},
                                    {"--crop", list},        {"--json", flag_only}, {"--max-pixels", number},
                                    {"--max-memory", number}};
const std::vector<Flag> kMethods = {{"--help", flag_only}};

const std::vector<std::string> kInPaths = {
    "c.exr",      "z.exr",      "c.png",          "d.png",    "m.png",     "layers.exr", "c.jpg",   "c.tif",
    "c.####.exr", "c.%04d.exr", "missing.exr",    "fifo.exr", "dir.exr",   "loop.exr",   "",        "c%%.exr",
    "c.%d.exr",   "c.%5d.exr",  "unreadable.exr", "huge.png", "out/o.exr", "c.exr/x",    "./c.exr", "z.####.exr"};
const std::vector<std::string> kOutPaths = {
    "out/o.exr", "out/o.png",     "out/o.jpg", "out/o.tif", "out/o.####.exr", "out/o.%04d.png",  "out/c.exr",  "c.exr",
    "out/o.txt", "missing/o.exr", "dir.exr",   "fifo.exr",  "out/%%.exr",     "out/o.%099d.exr", "out/ro.exr", ""};
const std::vector<std::string> kNumbers = {"0",      "1",     "-1",     "2.8",    "4",    "8",        "16",  "50",
                                           "1e-320", "1e308", "1e309",  "inf",    "-inf", "nan",      "1e6", "0.5",
                                           "1024",   "1025",  "100000", "1e-300", "0x10", "010",      "3.",  ".5",
                                           "1e",     "",      "2e11",   "1e18",   "64",   "268435456"};
const std::vector<std::string> kLists = {"1,2",          "3,2",      "0.5,2,4,20", "1,2,3,inf", "4,0.5,5,1",
                                         "1,5,5,10",     "0,0,8,6",  "1,2,3",      "a,b",       "1,,2",
                                         "1e-320,1,2,3", "-1,2,3,4", "0.1,1000",   "0.1,inf",   "0,0,100,100"};
const std::vector<std::string> kWords = {"reference",
                                         "scatter",
                                         "mcguire",
                                         "sterna",
                                         "starcraft",
                                         "layered",
                                         "z",
                                         "distance",
                                         "disparity",
                                         "ndc",
                                         "far",
                                         "error",
                                         "list",
                                         "zip",
                                         "piz",
                                         "none",
                                         "dwaa",
                                         "1-3",
                                         "1-3x2",
                                         "0-999999",
                                         "",
                                         "1",
                                         "x=1",
                                         "variant=book",
                                         "depth_softness=0.5",
                                         "samples=1e9",
                                         "inverse-z",
                                         "coc"};

const std::vector<std::string>& dictionary(Kind k) {
  switch (k) {
    case in_path:
      return kInPaths;
    case out_path:
      return kOutPaths;
    case number:
      return kNumbers;
    case list:
      return kLists;
    default:
      return kWords;
  }
}

void make_inputs() {
  char tmpl[] = "/tmp/dofkit-fuzz-cli-XXXXXX";
  if (!::mkdtemp(tmpl)) fuzz::bug("cannot make a folder");
  g_dir = tmpl;
  if (::chdir(g_dir.c_str()) != 0) fuzz::bug("cannot enter the folder");
  const int w = 8, h = 6;
  Image c(w, h, 4, 1.0f), z(w, h, 1);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      c.at(x, y, 0) = x / 8.0f, c.at(x, y, 1) = y / 6.0f, c.at(x, y, 2) = 0.5f;
      z.at(x, y) = 1.0f + (x + y) % 5;
    }
  io::WriteOptions zo;
  zo.channel_name = "Z";
  io::write_image("c.exr", c);
  io::write_image("z.exr", z, zo);
  for (const char* f : {"c.0001.exr", "c.0002.exr", "c.0003.exr"}) io::write_image(f, c);
  for (const char* f : {"z.0001.exr", "z.0002.exr"}) io::write_image(f, z, zo);
  io::write_image("c.png", c);
  io::write_image("c.jpg", c);
  io::write_image("c.tif", c);
  Image d(w, h, 1);
  for (std::size_t i = 0; i < d.plane_size(); ++i) d.plane(0)[i] = 0.2f + 0.1f * (i % 7);
  io::WriteOptions b16;
  b16.bits = 16;
  io::write_image("d.png", d, b16);
  io::write_image("m.png", d);
  Frame layered;
  layered.layer_color = {c, c};
  layered.layer_depth = {z, z};
  for (float& v : layered.layer_depth[1].data()) v += 1;
  io::write_layers_exr("layers.exr", layered);
  // A PNG header declaring 40000 x 40000 px (beyond the fuzz budget).
  {
    std::ofstream f("huge.png", std::ios::binary);
    const unsigned char png[] = {0x89, 'P',  'N',  'G', '\r', '\n', 0x1a, '\n', 0, 0, 0, 13, 'I', 'H', 'D', 'R', 0,
                                 0,    0x9c, 0x40, 0,   0,    0x9c, 0x40, 8,    2, 0, 0, 0,  0,   0,   0,   0};
    f.write(reinterpret_cast<const char*>(png), sizeof png);
  }
  ::mkfifo("fifo.exr", 0600);
  fs::create_directory("dir.exr");
  fs::create_directory("out");
  ::symlink("loop.exr", "loop.exr");
  io::write_image("unreadable.exr", c);
  ::chmod("unreadable.exr", 0);
  io::write_image("out/ro.exr", c);
  ::chmod("out/ro.exr", 0444);
  for (const auto& e : fs::directory_iterator(".")) {
    g_inputs.insert(e.path().filename().string());
    std::error_code ec;
    if (e.is_regular_file(ec)) g_sizes.push_back({e.path().string(), static_cast<long>(e.file_size(ec))});
  }
  g_inputs.insert("ro.exr");
}

// Removes what the run wrote; a temporary file left behind is a bug.
void clean(const std::string& folder) {
  DIR* d = ::opendir(folder.c_str());
  if (!d) return;
  std::vector<std::string> names;
  while (const dirent* e = ::readdir(d)) names.push_back(e->d_name);
  ::closedir(d);
  for (const std::string& n : names) {
    if (n == "." || n == "..") continue;
    if (n.find(".dofkit-tmp-") != std::string::npos) fuzz::bug("a temporary file was left behind: " + n);
    if (g_inputs.count(n) && (folder == "." || n == "ro.exr")) continue;
    if (folder == "." && n == "out") continue;
    fs::remove_all(folder + "/" + n);
  }
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  fuzz::setup();
  make_inputs();
  // The commands' own lines (a table, "wrote …") are not wanted 100,000 times.
  static std::ostringstream sink;
  std::cout.rdbuf(sink.rdbuf());
  std::cerr.rdbuf(sink.rdbuf());
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  std::size_t i = 0;
  const std::uint8_t head = data[i++];
  const int which = head % 3;
  const char* sub = which == 0 ? "render" : which == 1 ? "compare" : "methods";
  const std::vector<Flag>& flags = which == 0 ? kRender : which == 1 ? kCompare : kMethods;
  std::vector<std::string> args = {"dofkit", sub};
  if (which == 0 && (head & 0x80))
    args.insert(args.end(), {"--color", "c.exr", "--output", "out/o.exr", "--focus", "4", "--blur-at-infinity", "8",
                             "--threads", "1"});
  if (which == 1 && (head & 0x80)) args.insert(args.end(), {"c.exr", "c.png"});
  for (int pairs = 0; i + 1 < size && pairs < 24; ++pairs) {
    const Flag& f = flags[data[i++] % flags.size()];
    if (f.name[0] == '-') args.push_back(f.name);
    if (f.kind == flag_only) continue;
    const std::uint8_t v = data[i++];
    if (v < 224) {
      const auto& dict = dictionary(f.kind);
      args.push_back(dict[v % dict.size()]);
    } else {
      std::string s;
      for (int n = v - 224; n > 0 && i < size; --n, ++i)
        if (data[i] != '/' && data[i] != 0) s += static_cast<char>(data[i]);
      args.push_back(s);
    }
  }
  CLI::App app{"dofkit"};
  app.require_subcommand(1);
  cli::add_render_command(app);
  cli::add_compare_command(app);
  cli::add_methods_command(app);
  std::vector<std::string> rev(args.rbegin(), args.rend() - 1);  // CLI11 takes them reversed, without argv[0]
  try {
    app.parse(rev);
  } catch (const CLI::ParseError&) {
  } catch (const Error& e) {
    if (e.kind() == ErrorKind::internal) fuzz::bug(std::string("internal error: ") + e.what());
    if (std::string(e.what()).find('\n') != std::string::npos) fuzz::bug("a message of more than one line");
  } catch (const std::exception& e) {
    fuzz::bug(std::string("an exception that is not a dofkit::Error: ") + e.what());
  }
  clean(".");
  clean("out");
  for (const auto& [path, bytes] : g_sizes) {
    std::error_code ec;
    if (static_cast<long>(fs::file_size(path, ec)) != bytes || ec) fuzz::bug("input " + path + " was changed");
  }
  return 0;
}
