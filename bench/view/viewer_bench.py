#!/usr/bin/env python3
"""Viewer benchmark on the paper demo's output, in headless Chromium (SwiftShader WebGL).

  python3 bench/view/viewer_bench.py --dome build/bin/dome [--work DIR] [--screenshot PNG]

Makes the demo output once (dome synth --preset paper; dome fuse --texture --glb) in --work
and reuses it. Then, with `dome view` serving it, measures for each mesh variant the
time from navigation to the first frame with the mesh drawn (a fresh page, browser
cache disabled), and, playing the textured sequence, the rendered frames per second
and the instants shown per second, at the seed's 6 Hz and as fast as the page can go.
Then the same output as a 4D file (`dome export`, OUT/demo.dome4d): the time from
navigation to its first drawn frame, and, playing its instants once at the timeline's
rate, the frame times measured by the page (frames per second, the slowest frame) and
the instants shown. One JSON line per measurement. --screenshot writes a picture of the page (a camera
picked, its image and depth shown) for the README.
"""

import argparse
import json
import os
import subprocess
import sys
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..",
                                "tests", "view"))
import cdp  # noqa: E402


def make_output(dome, work):
    take, out = os.path.join(work, "take"), os.path.join(work, "out")
    if not os.path.exists(os.path.join(out, ".complete")):
        t = time.time()
        subprocess.run([dome, "synth", "--preset", "paper", "--no-tape", "--overwrite",
                        "--out", take], check=True, stdout=subprocess.DEVNULL)
        t_synth = time.time() - t
        t = time.time()
        subprocess.run([dome, "fuse", take, "--out", out, "--texture", "--glb"], check=True,
                       stdout=subprocess.DEVNULL)
        print(json.dumps({"made_output": work, "synth_s": round(t_synth, 1),
                          "fuse_s": round(time.time() - t, 1)}))
        open(os.path.join(out, ".complete"), "w").close()
    return take, out


def first_draw(b, url, variant):
    b.call("Page.navigate", url="about:blank")
    b.navigate("%s?variant=%s" % (url, variant))
    b.wait_for("(() => { const s = domeViewer.state(); return s.settled && s.firstDrawMs !== null"
               " || s.missing; })()", 120)
    s = b.eval("domeViewer.state()")
    assert not s["missing"], s
    return s["firstDrawMs"]


def playback(b, url, rate, seconds):
    b.navigate("%s?variant=textured&rate=%g" % (url, rate))
    b.wait_for("domeViewer.state().drawnInstant === 0", 120)
    time.sleep(1.0)  # let the prefetch of the next instants start as a user's would
    b.click_element("#play")
    s0, t0 = b.eval("domeViewer.state()"), time.time()
    time.sleep(seconds)
    s1, t1 = b.eval("domeViewer.state()"), time.time()
    b.click_element("#play")
    dt = t1 - t0
    return {"fps": (s1["frames"] - s0["frames"]) / dt,
            "instants_per_s": (s1["shown"] - s0["shown"]) / dt}


def sequence_first_draw(b, url):
    b.call("Page.navigate", url="about:blank")
    b.navigate("%s?sequence=out/demo.dome4d" % url)
    b.wait_for("domeViewer.state().firstDrawMs !== null", 120)
    return b.eval("domeViewer.state()")


def sequence_playback(b, url, speed, cameras):
    """Plays every instant once; the page's frame times while it does."""
    b.navigate("%s?sequence=out/demo.dome4d" % url)
    b.wait_for("domeViewer.state().sequence && domeViewer.state().sequence.done", 120)
    b.eval("domeViewer.setCamerasVisible(%s)" % ("true" if cameras else "false"))
    n = b.eval("domeViewer.state().sequence.instants.length")
    b.eval("domeViewer.setLoop(false); domeViewer.setSpeed(%g); domeViewer.show(0)" % speed)
    b.wait_for("domeViewer.state().drawnInstant === 0", 60)
    time.sleep(1.0)  # the page's first frames after a change compile its shaders
    t0 = b.eval("performance.now()")
    b.eval("domeViewer.setPlaying(true)")
    seen, frames, deadline = set(), [], time.time() + 120
    while time.time() < deadline:
        s = b.eval("domeViewer.state()")
        if s["drawnInstant"] is not None:
            seen.add(s["drawnInstant"])
        frames += [t for t in b.eval("domeViewer.frameTimes()") if t > t0 and (not frames or t > frames[-1])]
        if not s["playing"]:
            break
        time.sleep(0.05)
    gaps = [b_ - a for a, b_ in zip(frames, frames[1:])]
    return {"cameras_drawn": cameras, "antialias": s["antialias"],
            "instants": n, "instants_drawn": len(seen), "frames": len(frames),
            "render_fps": round(1000 * len(gaps) / (frames[-1] - frames[0]), 1) if gaps else 0,
            "slowest_frame_ms": round(max(gaps), 1) if gaps else None,
            "stats": s["stats"]}


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--dome", required=True)
    ap.add_argument("--work", default="/tmp/dome_view_bench")
    ap.add_argument("--seconds", type=float, default=8.0, help="playback measured, s")
    ap.add_argument("--screenshot", help="write a PNG of the page here")
    args = ap.parse_args()
    take, out = make_output(args.dome, args.work)
    view = cdp.DomeView(args.dome, out, take)
    b = cdp.Browser(1280, 800)
    try:
        b.call("Network.enable")
        b.call("Network.setCacheDisabled", cacheDisabled=True)
        for variant in ("textured", "decimated", "fused"):
            ms = first_draw(b, view.url, variant)
            print(json.dumps({"variant": variant, "first_drawn_frame_ms": round(ms)}))
        for rate in (6, 1000):
            r = playback(b, view.url, rate, args.seconds)
            print(json.dumps({"play_rate_hz": rate, "render_fps": round(r["fps"], 1),
                              "instants_per_s": round(r["instants_per_s"], 2)}))
        sequence = os.path.join(out, "demo.dome4d")
        if not os.path.exists(sequence):
            subprocess.run([args.dome, "export", out, "--out", sequence], check=True,
                           stdout=subprocess.DEVNULL)
        for _ in range(3):
            s = sequence_first_draw(b, view.url)
            print(json.dumps({"source": "demo.dome4d", "bytes": os.path.getsize(sequence),
                              "first_drawn_frame_ms": round(s["firstDrawMs"]),
                              "bytes_in_at_first_instant":
                                  s["sequence"]["instants"][0]["readyAtBytes"]}))
        for cameras in (True, False):
            r = sequence_playback(b, view.url, 1, cameras)
            print(json.dumps({"source": "demo.dome4d", "speed": 1, **r}))
        if args.screenshot:
            b.navigate(view.url + "?variant=textured")
            b.wait_for("domeViewer.state().drawnInstant === 0", 120)
            for cam in b.eval("DOME_INDEX.cameras.map(c => c.id)"):
                p = b.eval("domeViewer.frustumPoint(%s)" % json.dumps(cam))
                if p and 200 < p[0] < 900 and 60 < p[1] < 600:
                    b.click(p[0], p[1])
                    if not b.eval("document.getElementById('camera-panel').hidden"):
                        break
            b.wait_for("document.getElementById('camera-image').complete", 10)
            time.sleep(0.5)
            with open(args.screenshot, "wb") as f:
                f.write(b.screenshot_png(scale=0.75))  # README picture: keep it small
            print(json.dumps({"screenshot": args.screenshot,
                              "bytes": os.path.getsize(args.screenshot)}))
    finally:
        view.stop()
        b.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
