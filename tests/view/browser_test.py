#!/usr/bin/env python3
"""End-to-end test of `dome view` in headless Chromium (DevTools protocol).

Makes a small synthetic take and its fused/decimated/textured output, breaks one
instant's meshes and removes another's textured mesh, then checks in the browser that
the mesh is drawn (canvas pixels where the mesh projects differ from the background and
are background again with the mesh hidden), that play advances the VITC label through
every instant, that the broken and missing instants are shown as missing with a message
while the others still draw, that clicking a camera's frustum shows its image, depth map and
mask, that error colouring loads, and that the static export draws from file://.
Exit 0: passed; 1: failed; 77: skipped (Chromium or python3-websocket absent).
"""

import json
import os
import shutil
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import cdp  # noqa: E402


def label_of(name):
    return name.replace("-", ":")


def mesh_pixels_check(b, what):
    """Asserts the mesh is drawn where it projects: the canvas pixels inside its projected
    triangles change when the mesh is hidden, and are then the background colour."""
    def diff(p, q):
        return sum(abs(p[k] - q[k]) for k in range(3))

    # A mesh still being swapped in when the pixels are read shows as undrawn: look again
    # (up to three times, a second apart) before judging.
    for attempt in range(3):
        if attempt:
            time.sleep(1)
        b.eval("domeViewer.setCamerasVisible(false)")
        points = b.eval("domeViewer.projectMesh(200)")
        assert len(points) >= 50, "%s: only %d triangles project into the canvas" % (what, len(points))
        shown = b.eval("domeViewer.readPixels(%s)" % json.dumps(points))
        b.eval("domeViewer.setMeshVisible(false)")
        hidden = b.eval("domeViewer.readPixels(%s)" % json.dumps(points + [[5, 5]]))
        b.eval("domeViewer.setMeshVisible(true)")
        b.eval("domeViewer.setCamerasVisible(true)")
        background = hidden.pop()
        drawn = sum(diff(p, q) > 6 for p, q in zip(shown, hidden)) / len(points)
        if drawn >= 0.95:
            break
    not_bg = sum(diff(q, background) > 0 for q in hidden) / len(points)
    print("%s: %d projected triangles, %.0f%% of their centroids' pixels change when the mesh is hidden, "
          "%.0f%% then differ from the background %s" % (what, len(points), 100 * drawn,
                                                          100 * not_bg, background))
    assert background == [0x1d, 0x21, 0x27], "%s: background is %s" % (what, background)
    assert drawn >= 0.95, "%s: mesh not drawn where it projects (%.2f)" % (what, drawn)
    assert not_bg == 0, "%s: pixels differ from the background without the mesh" % what


def state(b):
    return b.eval("domeViewer.state()")


def wait_settled(b, index, timeout_s=60):
    b.wait_for("(() => { const s = domeViewer.state(); return s.index === %d && s.settled; })()"
               % index, timeout_s)
    return state(b)


def main():
    args = cdp.test_arguments()
    if args is None:
        return cdp.SKIP

    t0 = time.time()
    tmp = tempfile.mkdtemp(prefix="dome_view_browser_")
    take, out, exported = (os.path.join(tmp, d) for d in ("take", "out", "export"))
    run = lambda *a: subprocess.run([args.dome, *a], check=True, stdout=subprocess.DEVNULL)
    run("synth", "--preset", "small", "--instants", "4", "--no-tape", "--out", take)
    run("fuse", take, "--out", out, "--texture", "--glb", "--voxel-mm", "40")
    instants = sorted(d for d in os.listdir(out) if os.path.isdir(os.path.join(out, d)))
    assert len(instants) == 4, instants
    broken, untextured = instants[1], instants[3]
    for f in ("mesh.ply", "mesh_decimated.ply", "textured.obj", "textured.glb"):
        with open(os.path.join(out, broken, f), "wb") as fh:
            fh.write(b"ply\nformat binary_little_endian 1.0\nthis is not a mesh\n")
    for f in ("textured.obj", "textured.mtl", "textured.png", "textured.glb"):
        os.remove(os.path.join(out, untextured, f))
    # The first instant's textured mesh is read from OBJ + PNG, the others' from GLB.
    os.remove(os.path.join(out, instants[0], "textured.glb"))
    print("output made in %.1f s" % (time.time() - t0))

    view = cdp.DomeView(args.dome, out, take)
    b = cdp.Browser()
    try:
        # 1. The decimated mesh of the first instant is drawn.
        b.navigate(view.url + "?variant=decimated&rate=5")
        s = wait_settled(b, 0)
        assert s["drawnInstant"] == 0 and not s["missing"], s
        assert s["timecode"] == label_of(instants[0]), s
        mesh_pixels_check(b, "served, decimated")

        # 2. Play: the label goes through every instant in order; the broken one is
        # shown as missing with the loader's message, the others are drawn.
        b.click_element("#play")
        seen, previous, deadline = [], 0, time.time() + 20
        while len(seen) < len(instants) and time.time() < deadline:
            s = state(b)
            if s["settled"] and s["index"] != previous:
                seen.append(s)
                previous = s["index"]
            time.sleep(0.02)
        b.click_element("#play")
        labels = [x["timecode"] for x in seen]
        print("played:", labels)
        expected = [label_of(n) for n in instants[1:]] + [label_of(instants[0])]
        assert labels == expected, "played %s, expected %s" % (labels, expected)
        for x in seen:
            if x["timecode"] == label_of(broken):
                assert x["missing"] and x["drawnInstant"] is None, x
                assert "missing" in x["status"] and "mesh_decimated.ply" in x["status"], x
                assert "PLY" in x["status"], x
            else:
                assert not x["missing"] and x["drawnInstant"] == x["index"], x
        assert not state(b)["playing"]

        # 3. Textured: drawn from OBJ + atlas, and from GLB; the instant without one
        # says so.
        b.eval("(() => { const v = document.getElementById('variant'); v.value = 'textured';"
               " v.dispatchEvent(new Event('change')); })()")
        s = wait_settled(b, 0)
        assert s["drawnInstant"] == 0 and s["status"] == "", s
        mesh_pixels_check(b, "served, textured OBJ")
        b.click_element("#step-forward")
        b.click_element("#step-forward")
        s = wait_settled(b, 2)
        assert s["drawnInstant"] == 2 and s["status"] == "", s
        mesh_pixels_check(b, "served, textured GLB")
        b.click_element("#step-forward")
        s = wait_settled(b, 3)
        assert s["missing"] and "no textured mesh was written" in s["status"], s
        print("missing instant says:", s["status"])

        # 4. Clicking a camera's frustum shows its image and depth map for the instant.
        b.click_element("#step-forward")
        wait_settled(b, 0)
        cams = b.eval("DOME_INDEX.cameras.map(c => [c.id, c.width_px, c.height_px])")
        clicked = None
        for cam_id, width, height in cams:
            p = b.eval("domeViewer.frustumPoint(%s)" % json.dumps(cam_id))
            if not p or not (0 < p[0] < b.width and 0 < p[1] < b.height - 60):
                continue
            b.click(p[0], p[1])
            title = b.eval("document.getElementById('camera-panel').hidden ? null :"
                           " document.getElementById('camera-title').textContent")
            if title and title.startswith(cam_id + " "):
                clicked = (cam_id, width, height)
                break
        assert clicked, "no frustum could be clicked"
        cam_id, width, height = clicked
        b.wait_for("(() => { const i = document.getElementById('camera-image');"
                   " return i.complete && i.naturalWidth > 0; })()", 10)
        b.wait_for("(() => { const i = document.getElementById('camera-depth');"
                   " return i.complete && i.naturalWidth > 0; })()", 10)
        img = b.eval("(() => { const i = document.getElementById('camera-image');"
                     " return [i.naturalWidth, i.naturalHeight, i.getAttribute('src')]; })()")
        depth = b.eval("(() => { const i = document.getElementById('camera-depth');"
                       " return [i.naturalWidth, i.naturalHeight, i.getAttribute('src')]; })()")
        print("camera %s: image %s, depth %s" % (cam_id, img, depth))
        assert img == [width, height, "take/frames/%s/%s.png" % (instants[0], cam_id)], img
        assert depth[:2] == [width, height], depth
        # Beside them the camera's mask (the take's background plates): the image
        # darkened outside it, its outline in pure green where the person is.
        b.wait_for("(() => { const i = document.getElementById('camera-mask');"
                   " return i.complete && i.naturalWidth > 0; })()", 20)
        mask = b.eval("(() => { const i = document.getElementById('camera-mask');"
                      " return [i.naturalWidth, i.naturalHeight, i.getAttribute('src')]; })()")
        caption = b.eval("document.getElementById('mask-caption').textContent")
        green = b.eval("(() => { const i = document.getElementById('camera-mask');"
                       " const c = document.createElement('canvas'); c.width = i.naturalWidth;"
                       " c.height = i.naturalHeight; const g = c.getContext('2d'); g.drawImage(i, 0, 0);"
                       " const d = g.getImageData(0, 0, c.width, c.height).data; let n = 0;"
                       " for (let k = 0; k < d.length; k += 4)"
                       "   if (d[k] === 0 && d[k + 1] === 255 && d[k + 2] === 0) ++n;"
                       " return n; })()")
        print("camera %s: mask %s, %r, %d outline pixels" % (cam_id, mask, caption, green))
        assert mask == [width, height, "derived/mask/%s/%s.png" % (instants[0], cam_id)], mask
        assert caption == "mask (plate), background darkened", caption
        assert green > 20, green

        # 5. Error colouring against the truth mesh, with the legend in mm.
        b.eval("(() => { const v = document.getElementById('variant'); v.value = 'decimated';"
               " v.dispatchEvent(new Event('change'));"
               " const c = document.getElementById('colouring'); c.value = 'error';"
               " c.dispatchEvent(new Event('change')); })()")
        b.wait_for("domeViewer.state().errorColoured", 20)
        legend = b.eval("document.getElementById('legend').hidden ? null :"
                        " document.getElementById('legend').textContent")
        assert legend and "mm" in legend, legend
        mesh_pixels_check(b, "served, error colours")
        assert not b.console, b.console
    finally:
        code = view.stop()
        b.close()
    assert code == 0, "dome view exited %s on SIGTERM" % code

    # 6. The static export draws from file:// without a server.
    subprocess.run([args.dome, "view", out, "--take", take, "--export", exported], check=True,
                   stdout=subprocess.DEVNULL)
    b = cdp.Browser()
    try:
        b.navigate("file://" + exported + "/index.html?variant=textured")
        s = wait_settled(b, 0)
        assert s["drawnInstant"] == 0 and s["status"] == "", s
        mesh_pixels_check(b, "export, textured")
        b.eval("domeViewer.show(1)")
        s = wait_settled(b, 1)
        assert s["missing"] and "textured.glb" in s["status"], s
        assert not b.console, b.console
        # The masks are exported beside the images.
        assert os.path.getsize(os.path.join(exported, "derived", "mask", instants[0],
                                            cam_id + ".png")) > 0
    finally:
        b.close()
    if not args.keep:
        shutil.rmtree(tmp, ignore_errors=True)
    print("browser test passed in %.1f s" % (time.time() - t0))
    return 0


if __name__ == "__main__":
    sys.exit(main())
