// Where the viewer page lives: index.html, viewer.js, viewer.css and three/ (three.js
// r111 and its non-module loaders and OrbitControls from Debian's libjs-three), copied
// by the build to <build>/share/dome/viewer and installed to <prefix>/share/dome/viewer.
#pragma once

#include <filesystem>

namespace dome::view {

// The page's files the viewer needs, relative to the assets folder.
inline constexpr const char* kAssetFiles[] = {
    "index.html",
    "viewer.js",
    "viewer.css",
    "three/three.min.js",
    "three/OrbitControls.js",
    "three/PLYLoader.js",
    "three/OBJLoader.js",
    "three/GLTFLoader.js",
};

// The assets folder: $DOME_VIEWER_DIR when set, else ../share/dome/viewer next to the
// running executable. Throws core::InputError naming the folder and the missing file
// when it is incomplete.
std::filesystem::path FindViewerAssets();

}  // namespace dome::view
