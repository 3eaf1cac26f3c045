// The page's files (host/ui/web/ and the scope library uPlot from npm),
// embedded into the executable at build time (embed_web_assets.cmake), so
// `piezoloop ui` serves them offline, from any directory.
#pragma once

#include <cstddef>
#include <span>
#include <string_view>

namespace piezoloop::ui {

struct WebAsset {
    std::string_view path;          // URL path, "/console.js"
    std::string_view content_type;
    std::string_view body;
};

std::span<const WebAsset> web_assets();

}  // namespace piezoloop::ui
