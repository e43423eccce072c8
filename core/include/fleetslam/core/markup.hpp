#pragma once
// Text for hand-written SVG and HTML: escaping for element text and quoted attribute values.

#include <string>
#include <string_view>

namespace fleetslam::core {

// `text` with & < > " ' replaced by their entities.
std::string escape_markup(std::string_view text);

}  // namespace fleetslam::core
