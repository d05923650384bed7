"""Renders the peer scene with Mitsuba 3 (thin lens) and prints one JSON line of timings.

Run in its own process per variant (a Mitsuba process picks one variant):
    python3 mitsuba_run.py VARIANT PLY WIDTH HEIGHT SPP MAX_DEPTH SETTINGS_JSON OUT.exr

Load time is `load_dict` alone (PLY read, BVH build). Set-up time is module import, scene loading plus the first render's extra cost (Dr.Jit tracing and compiling
the kernels in the llvm variant); the camera-sample rate comes from a second, timed render
of the same scene at the same spp.
"""

import json
import sys
import time


def main() -> None:
    variant, ply, width, height, spp, max_depth, settings, out = sys.argv[1:9]
    width, height, spp, max_depth = int(width), int(height), int(spp), int(max_depth)
    settings = json.loads(settings)
    start = time.perf_counter()
    import mitsuba as mi

    mi.set_variant(variant)
    T = mi.ScalarTransform4f
    load_start = time.perf_counter()
    scene = mi.load_dict(
        {
            "type": "scene",
            # Mitsuba counts path segments: max_depth 2 is direct lighting only, so pbrt's and
            # realcam's depth D is Mitsuba's D + 1 (passed in already converted).
            "integrator": {"type": "path", "max_depth": max_depth},
            "sensor": {
                "type": "thinlens",
                "fov": settings["fov_x_deg"],
                "fov_axis": "x",
                "aperture_radius": settings["aperture_radius_m"],
                "focus_distance": settings["focus_distance_m"],
                "to_world": T().look_at(
                    origin=settings["eye"], target=settings["target"], up=[0, 1, 0]
                ),
                "film": {
                    "type": "hdrfilm",
                    "width": width,
                    "height": height,
                    "rfilter": {"type": "box"},
                },
                "sampler": {"type": "independent", "sample_count": spp},
            },
            "sky": {"type": "constant", "radiance": {"type": "rgb", "value": 1.0}},
            "model": {
                "type": "ply",
                "filename": ply,
                "face_normals": True,
                "bsdf": {"type": "diffuse", "reflectance": {"type": "rgb", "value": 0.5}},
            },
        }
    )
    loaded = time.perf_counter()
    image = mi.render(scene, spp=spp, seed=0)
    mi.Bitmap(image).write(out)  # forces evaluation of the whole image
    first = time.perf_counter()
    image = mi.render(scene, spp=spp, seed=1)
    mi.Bitmap(image).write(out)
    second = time.perf_counter()
    render_seconds = second - first
    print(
        json.dumps(
            {
                "render_seconds": render_seconds,
                "setup_seconds": (loaded - start) + max(0.0, (first - loaded) - render_seconds),
                # Reading the PLY and building the acceleration structure (load_dict).
                "load_seconds": loaded - load_start,
                "samples_per_second": width * height * spp / render_seconds,
            }
        )
    )


if __name__ == "__main__":
    main()
