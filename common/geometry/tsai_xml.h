// Tsai camera files in the XML schema of the PETS / EPFL multi-camera data sets
// (e.g. the EPFL "terrace" sequence), as written by their Tsai calibration tools.
//
// Format (one camera per file; attribute order free; other elements and attributes
// are ignored; values are decimal numbers):
//
//   <?xml version="1.0" encoding="UTF-8"?>
//   <Camera name="camera0">
//     <Geometry width="720" height="576" ncx="576" nfx="576"
//               dx="2.3e-02" dy="2.3e-02" dpx="2.3e-02" dpy="2.3e-02"/>
//     <Intrinsic focal="20.161920" kappa1="5.720865e-04" cx="366.514507"
//                cy="305.832552" sx="1"/>
//     <Extrinsic tx="-4844.19" ty="551.09" tz="4966.74"
//                rx="1.9007833770" ry="0.49730769727" rz="0.18415452559"/>
//   </Camera>
//
//  Geometry:  width, height   image size, pixels (integers)
//             ncx, nfx        sensor elements in x, frame-grabber pixels per line
//             dx, dy          sensor element pitch, mm
//             dpx, dpy        effective pixel pitch, mm; redundant: dpx = dx * ncx / nfx,
//                             dpy = dy (Tsai). The reader checks both to 1e-6 relative
//                             and rejects a file where they disagree (TsaiCamera
//                             derives dpx from dx, ncx, nfx, so a disagreeing file
//                             would otherwise project differently from Willson's code,
//                             which uses the stored dpx).
//  Intrinsic: focal           effective focal length, mm
//             kappa1          radial distortion, 1/mm^2 (Tsai: distorted -> undistorted)
//             cx, cy          image centre, pixels (Tsai frame-buffer coordinates,
//                             (0, 0) the centre of the top-left pixel)
//             sx              horizontal scale factor
//  Extrinsic: tx, ty, tz      translation, mm, world -> camera
//             rx, ry, rz      Tsai's Euler angles, radians: R = Rz(rz) Ry(ry) Rx(rx)
//                             (tsai_camera.h), world -> camera
//
// The mapping to TsaiCamera is exact in both directions: the file's units are the
// model's. The writer prints 17 significant digits, so write -> read returns the same
// camera up to the rounding of R -> angles -> R (~1e-16).
#pragma once

#include <string>

#include "geometry/tsai_camera.h"

namespace dome::geometry {

// Reads one camera. id = the Camera element's name attribute. Throws core::InputError
// naming the file and the element/attribute ("terrace-tsai-c0.xml: Intrinsic.focal")
// for a missing file, element or attribute, a value that is not a finite number, a
// non-positive size, pitch, count, focal or sx, and an inconsistent dpx / dpy.
TsaiCamera ReadTsaiXml(const std::string& path);

// Writes `camera` (which must pass Check; InputError naming `path` otherwise).
void WriteTsaiXml(const std::string& path, const TsaiCamera& camera);

}  // namespace dome::geometry
