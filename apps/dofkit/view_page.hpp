// The page `dofkit view` serves: one self-contained HTML document (CSS and JS inline, no
// external resource), in view_page.cpp.
#pragma once
#include <string>

namespace dofkit::cli {

const std::string& view_page();

}  // namespace dofkit::cli
