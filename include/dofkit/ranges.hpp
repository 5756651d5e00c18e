// dofkit — the documented range of every numeric parameter, in one table.
//
// Every number a user can give (the camera models' fields, the CLI's numeric flags) has a
// range here that excludes non-finite values, subnormals and values whose products overflow
// (a thin lens with f/1e-320 made K = inf, and inf · 0 a NaN radius). validate(CameraModel)
// and the CLI check their values against it, the CLI help prints each flag's range from it,
// and docs/cli.md's table of ranges is checked against it by a test. A new numeric flag is
// one more row in src/core/ranges.cpp.
#pragma once
#include <string>
#include <vector>

namespace dofkit {

/// One parameter's range.
struct NumericRange {
  /// The flag as the CLI spells it ("--f-number"), or "<command> <flag>" where a command's
  /// flag of that name has a range of its own ("scene --layers").
  const char* name;
  const char* unit;  ///< "mm", "m", "px", "deg", "MiB", … or "" (dimensionless)
  double min, max;   ///< bounds, inclusive unless min_open / max_open
  bool min_open = false, max_open = false;
  bool integer = false;      ///< whole numbers only
  bool infinity_ok = false;  ///< +inf is accepted besides the range (e.g. the far-blurry plane)
  const char* note = "";     ///< what else applies (a cross-parameter rule), for the docs
};

/// Every row, in the table's order.
const std::vector<NumericRange>& numeric_ranges();

/// The row of `name` (e.g. "--f-number" or "scene --layers"); throws Error(internal) if the
/// table has none.
const NumericRange& numeric_range(const std::string& name);

/// Checks `value` against the row of `name`: throws Error(usage) "<flag> <value>: must be …"
/// (`shown` is how the user wrote it; empty: the value printed). Returns the value.
double check_number(const std::string& name, double value, const std::string& shown = "");

/// Parses `text` as one number strictly (decimal, optional exponent; "inf" only where the
/// row allows it; no trailing characters, no NaN, no hexadecimal) and checks it. Throws
/// Error(usage) naming the flag.
double parse_number(const std::string& name, const std::string& text);

/// The range as the help and the docs print it, e.g. "0.1 to 10000 mm",
/// "1 to 1024 (whole number)", "more than 0 and less than 180 deg".
std::string range_text(const NumericRange& range);

/// The Markdown table of every row (docs/cli.md holds it; a test compares the two).
std::string numeric_ranges_markdown();

}  // namespace dofkit
