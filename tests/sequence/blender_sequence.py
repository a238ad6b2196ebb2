# Run inside Blender (blender -b --python-exit-code 1 --python THIS -- FILE.glb FPS OUT.json):
# imports a glTF sequence with Blender's own glTF importer and writes, for every frame of
# the scene range the import set, the mesh objects that are visible (non-zero world
# scale) and their vertex counts. The C++ test reads OUT.json.
import json
import sys

import numpy

# Debian's numpy 1.24 dropped the alias numpy.bool that Blender 3.4's glTF importer uses.
numpy.bool = bool

import bpy  # noqa: E402

path, fps, out = sys.argv[sys.argv.index("--") + 1:][:3]
bpy.ops.wm.read_factory_settings(use_empty=True)
scene = bpy.context.scene
scene.render.fps = int(fps)  # the importer turns keyframe seconds into frames at this rate
# glTF keeps one vertex per (position, texture coordinate); merging gives back the mesh's
# own vertices, texture coordinates staying per face corner.
bpy.ops.import_scene.gltf(filepath=path, merge_vertices=True)
meshes = [o for o in scene.objects if o.type == "MESH"]
# The importer keys the actions at seconds * fps and leaves the scene's range alone: the
# range played is that of the imported actions.
ranges = [o.animation_data.action.frame_range for o in meshes
          if o.animation_data and o.animation_data.action]
scene.frame_start = int(round(min(r[0] for r in ranges)))
scene.frame_end = int(round(max(r[1] for r in ranges)))
result = {"frame_start": scene.frame_start, "frame_end": scene.frame_end,
          "meshes": {o.name: len(o.data.vertices) for o in meshes}, "frames": []}
for frame in range(scene.frame_start, scene.frame_end + 1):
    scene.frame_set(frame)
    visible = [o.name for o in meshes if abs(o.matrix_world.determinant()) > 1e-15]
    result["frames"].append({"frame": frame, "visible": visible})
with open(out, "w") as f:
    json.dump(result, f)
