#!/usr/bin/env python3
"""Mitsuba 3's render of a room lit by a `spot` and a `directional` emitter, for
`tests/delta_lights.rs` (`mitsuba_3_and_vitrum_agree_on_spot_and_directional_lights`).

Writes, next to each other under tests/data/mitsuba3/:
  lights.xml  the scene (Mitsuba 3 XML, written here by hand, not by vitrum's exporter: vitrum
              imports it, so the test checks the importer and the lights at once);
  lights.exr  32x32, channels R, G, B: the mean of RENDERS independent renders (seeds 0..RENDERS-1)
              of SPP samples each by Mitsuba's `path` (max_depth -1, box filter), and
              variance.R/G/B: the variance of that mean per pixel (sample variance over the
              renders / RENDERS).

Run from the repository root:  python3 scripts/mitsuba3/lights.py
(needs `mitsuba` (scalar_rgb), numpy and OpenEXR for python3; about a minute on 2 cores).
"""

import os

import mitsuba as mi
import numpy as np
import OpenEXR

RENDERS = 16
SPP = 1024
OUT = os.path.join("tests", "data", "mitsuba3")

# The room of tests/delta_lights.rs (`lit_room`): a white floor and a red back wall (vitrum quads,
# here rectangles [-1, 1]^2 mapped by to_world), a white sphere, a spot light aimed at the origin
# and a directional light.
XML = """<?xml version="1.0" encoding="utf-8"?>
<scene version="3.0.0">
    <default name="spp" value="64"/>
    <default name="seed" value="0"/>
    <integrator type="path">
        <integer name="max_depth" value="-1"/>
    </integrator>
    <sensor type="perspective">
        <string name="fov_axis" value="y"/>
        <float name="fov" value="45"/>
        <transform name="to_world">
            <lookat origin="0, 1.5, 4" target="0, 0.4, 0" up="0, 1, 0"/>
        </transform>
        <sampler type="independent">
            <integer name="sample_count" value="$spp"/>
            <integer name="seed" value="$seed"/>
        </sampler>
        <film type="hdrfilm">
            <integer name="width" value="32"/>
            <integer name="height" value="32"/>
            <rfilter type="box"/>
        </film>
    </sensor>
    <bsdf type="twosided" id="white">
        <bsdf type="diffuse">
            <rgb name="reflectance" value="0.7, 0.7, 0.7"/>
        </bsdf>
    </bsdf>
    <bsdf type="twosided" id="red">
        <bsdf type="diffuse">
            <rgb name="reflectance" value="0.7, 0.2, 0.1"/>
        </bsdf>
    </bsdf>
    <!-- floor: x in [-2, 2], z in [-1, 2], y = 0, normal +y -->
    <shape type="rectangle">
        <transform name="to_world">
            <matrix value="2 0 0 0  0 0 1 0  0 -1.5 0 0.5  0 0 0 1"/>
        </transform>
        <ref id="white"/>
    </shape>
    <!-- back wall: x in [-2, 2], y in [0, 2], z = -1, normal +z -->
    <shape type="rectangle">
        <transform name="to_world">
            <matrix value="2 0 0 0  0 1 0 1  0 0 1 -1  0 0 0 1"/>
        </transform>
        <ref id="red"/>
    </shape>
    <shape type="sphere">
        <point name="center" x="0.2" y="0.4" z="0.2"/>
        <float name="radius" value="0.4"/>
        <ref id="white"/>
    </shape>
    <emitter type="spot">
        <rgb name="intensity" value="4, 4, 4"/>
        <float name="cutoff_angle" value="35"/>
        <transform name="to_world">
            <lookat origin="-0.8, 1.6, 1.0" target="0, 0, 0" up="0, 1, 0"/>
        </transform>
    </emitter>
    <emitter type="directional">
        <vector name="direction" x="0.4" y="-1" z="-0.5"/>
        <rgb name="irradiance" value="0.8, 0.8, 0.8"/>
    </emitter>
</scene>
"""


def main():
    mi.set_variant("scalar_rgb")
    os.makedirs(OUT, exist_ok=True)
    xml_path = os.path.join(OUT, "lights.xml")
    with open(xml_path, "w", encoding="utf-8") as f:
        f.write(XML)
    renders = []
    for seed in range(RENDERS):
        scene = mi.load_file(xml_path, spp=SPP, seed=seed)
        renders.append(np.array(mi.render(scene), dtype=np.float64)[:, :, :3])
    stack = np.stack(renders)
    mean = stack.mean(axis=0).astype(np.float32)
    variance = (stack.var(axis=0, ddof=1) / RENDERS).astype(np.float32)
    channels = {}
    for k, c in enumerate("RGB"):
        channels[c] = np.ascontiguousarray(mean[:, :, k])
        channels["variance." + c] = np.ascontiguousarray(variance[:, :, k])
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    with OpenEXR.File(header, channels) as f:
        f.write(os.path.join(OUT, "lights.exr"))
    print(f"mean {mean.mean():.6f}, image-mean standard error {np.sqrt(variance.sum()) / variance.size:.2e}")


if __name__ == "__main__":
    main()
