#!/usr/bin/env python3
"""The programs start without the libraries that made them slow to start.

  check_start_libraries.py MODULE PROGRAM...

Each PROGRAM's shared libraries (ldd: everything the dynamic loader maps and relocates
at start) must hold none of OpenCV's image codecs and video reader, ffmpeg's codec and
format libraries, GDAL or GStreamer: those are the ~200 libraries that took 0.1-0.2 s of
every start (README, "Dependencies"); video goes through MODULE (common/video/video.h),
whose own libraries must all resolve. Prints each offender and exits 1.
"""
import re
import subprocess
import sys

FORBIDDEN = re.compile(r"^(libopencv_imgcodecs|libopencv_videoio|libavcodec|libavformat|"
                       r"libswscale|libgdal|libgst)")


def libraries(path):
    out = subprocess.run(["ldd", path], check=True, capture_output=True, text=True).stdout
    return [line.split()[0] for line in out.splitlines() if "=>" in line], out


def main():
    module, programs = sys.argv[1], sys.argv[2:]
    problems = []
    for program in programs:
        libs, _ = libraries(program)
        for lib in libs:
            if FORBIDDEN.match(lib):
                problems.append(f"{program}: loads {lib} at start; reach it through the video "
                                "module or io's own codecs instead")
        print(f"{program}: {len(libs)} shared libraries")
    libs, text = libraries(module)
    if "not found" in text:
        problems.append(f"{module}: a library it needs is missing:\n{text}")
    if not any(l.startswith("libopencv_videoio") for l in libs):
        problems.append(f"{module}: does not link OpenCV's videoio")
    for p in problems:
        print(p)
    print(f"{len(problems)} problems")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
