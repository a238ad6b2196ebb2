// `dome export --format gltf-sequence`: the whole sequence as one binary glTF 2.0 file
// that DCC tools (Blender's glTF importer) open as one animation.
//
// Layout: one root node carrying mesh/gltf.h's world-to-glTF matrix (dome's mm, z up ->
// metres, y up), with one child node per instant (named by its HH-MM-SS-FF) holding
// that instant's textured mesh (its own atlas, embedded PNG; none for an instant
// without triangles). One animation,
// "sequence", animates every child's scale with STEP interpolation on the keyframe
// times of the instants (Sequence's timeline): scale 1 from its instant's start until
// the next instant's, 0 elsewhere, so exactly one instant shows at any time. The
// static pose (no animation applied) shows the first instant only. glTF has no
// visibility property in its core; a zero scale is what every importer honours.
#pragma once

#include <string>

#include "sequence/sequence.h"

namespace dome::sequence {

std::string EncodeGltfSequence(const Sequence& sequence);

}  // namespace dome::sequence
