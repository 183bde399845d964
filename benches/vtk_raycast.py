#!/usr/bin/env python3
"""VTK's GPU ray caster (vtkGPUVolumeRayCastMapper) on the scene of examples/render_benchmark.rs,
for comparing frame times on the same machine: same volume, image size, camera, sample distance
and classes.

Classes as render_benchmark makes them up: values from 1/4 of the value range up to 1/2 are a faint
class (hue 40, opacity 0.05..0.25), from 1/2 up an opaque one (hue 215, opacity 0.35..0.8), both at
saturation 0.7 and value 0.95; the opacity rises with the gradient magnitude up to a quarter of the
value range per mm (VTK: a scalar opacity step function times a gradient opacity ramp from 0.3 to
1, the two classes' mean ratio of low to high opacity). Shading: ambient 0.35, diffuse 0.65,
specular 0.25, power 24 (volasso's default lighting), jittered ray starts, no automatic sample
distance. Each frame turns the camera by 1 degree (as render_benchmark does) and waits for the GPU.

    pip install vtk numpy
    python3 benches/vtk_raycast.py VOLUME.raw --dims 256,256,256 --type uint8 [--spacing 1,1,1]
        [--size 1280x800] [--step-voxels 0.5] [--frames 10] [--warm-up 3] [--unshaded] [--save FIRST.png]

Prints `vtk-shaded-1280x800: median N ms over F frames (min, max)` and the OpenGL renderer.
Offscreen through EGL (Mesa's llvmpipe where there is no GPU): VTK_DEFAULT_OPENGL_WINDOW is set
to vtkEGLRenderWindow unless already set.
"""
import argparse
import colorsys
import math
import os
import sys
import time

os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")

import numpy as np  # noqa: E402
import vtk  # noqa: E402
from vtk.util import numpy_support  # noqa: E402

TYPES = {"uint8": np.uint8, "int8": np.int8, "uint16": np.uint16, "int16": np.int16, "float32": np.float32}


def triple(text, kind):
    values = [kind(v) for v in text.split(",")]
    if len(values) != 3:
        raise argparse.ArgumentTypeError(f"expected X,Y,Z, got {text}")
    return values


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("volume")
    parser.add_argument("--dims", type=lambda t: triple(t, int), required=True)
    parser.add_argument("--type", choices=sorted(TYPES), default="uint8")
    parser.add_argument("--spacing", type=lambda t: triple(t, float), default=[1.0, 1.0, 1.0])
    parser.add_argument("--size", default="1280x800")
    parser.add_argument("--step-voxels", type=float, default=0.5)
    parser.add_argument("--frames", type=int, default=10)
    parser.add_argument("--warm-up", type=int, default=3)
    parser.add_argument("--unshaded", action="store_true")
    parser.add_argument("--save", help="write the first timed frame as a PNG (to compare the views)")
    args = parser.parse_args()
    width, height = (int(v) for v in args.size.split("x"))
    dims, spacing = args.dims, args.spacing

    data = np.fromfile(args.volume, dtype=TYPES[args.type])
    if data.size != dims[0] * dims[1] * dims[2]:
        sys.exit(f"{args.volume}: {data.size} voxels, not {dims}")
    image = vtk.vtkImageData()
    image.SetDimensions(*dims)
    image.SetSpacing(*spacing)
    # volasso's world: the box dims * spacing centred on the origin, voxel centres inside it.
    extent = [d * s for d, s in zip(dims, spacing)]
    image.SetOrigin(*[-e / 2 + s / 2 for e, s in zip(extent, spacing)])
    image.GetPointData().SetScalars(numpy_support.numpy_to_vtk(data, deep=True))

    low, high = float(data.min()), float(data.max())
    thresholds = [low + f * (high - low) for f in (0.25, 0.5)]
    epsilon = 1e-3 * (high - low)
    classes = [(25.0, 0.05, 0.25), (200.0, 0.35, 0.8)]
    opacity = vtk.vtkPiecewiseFunction()
    colour = vtk.vtkColorTransferFunction()
    opacity.AddPoint(low, 0.0)
    opacity.AddPoint(thresholds[0] - epsilon, 0.0)
    for (hue, _, top), start, end in zip(classes, thresholds, thresholds[1:] + [high]):
        rgb = colorsys.hsv_to_rgb((hue + 15.0) / 360.0, 0.7, 0.95)
        opacity.AddPoint(start, top)
        opacity.AddPoint(end - epsilon if end < high else end, top)
        colour.AddRGBPoint(start, *rgb)
        colour.AddRGBPoint(end - epsilon if end < high else end, *rgb)
    min_spacing = min(spacing)
    gradient_max = 0.25 * (high - low) / min_spacing
    gradient_opacity = vtk.vtkPiecewiseFunction()
    gradient_opacity.AddPoint(0.0, 0.3)
    gradient_opacity.AddPoint(gradient_max, 1.0)

    volume_property = vtk.vtkVolumeProperty()
    volume_property.SetScalarOpacity(opacity)
    volume_property.SetColor(colour)
    volume_property.SetGradientOpacity(gradient_opacity)
    volume_property.SetInterpolationTypeToLinear()
    volume_property.SetScalarOpacityUnitDistance(min_spacing)
    if not args.unshaded:
        volume_property.ShadeOn()
        volume_property.SetAmbient(0.35)
        volume_property.SetDiffuse(0.65)
        volume_property.SetSpecular(0.25)
        volume_property.SetSpecularPower(24.0)

    mapper = vtk.vtkGPUVolumeRayCastMapper()
    mapper.SetInputData(image)
    mapper.SetAutoAdjustSampleDistances(0)
    mapper.SetLockSampleDistanceToInputSpacing(0)
    mapper.SetSampleDistance(args.step_voxels * min_spacing)
    mapper.SetUseJittering(1)
    actor = vtk.vtkVolume()
    actor.SetMapper(mapper)
    actor.SetProperty(volume_property)

    renderer = vtk.vtkRenderer()
    renderer.AddVolume(actor)
    renderer.SetBackground(0.0, 0.0, 0.0)
    window = vtk.vtkRenderWindow()
    window.SetOffScreenRendering(1)
    window.SetSize(width, height)
    window.AddRenderer(renderer)

    # volasso's Camera::default(): azimuth 30, elevation 20, 30-degree field of view, the
    # bounding sphere fitting the image height.
    camera = renderer.GetActiveCamera()
    radius = 0.5 * math.sqrt(sum(e * e for e in extent))
    fit = height / width if width < height else 1.0
    distance = radius * (1.0 / fit if fit < 1.0 else 1.0) / math.sin(math.radians(15.0))
    camera.SetViewAngle(30.0)

    def place(azimuth_degrees, elevation_degrees=20.0):
        a, e = math.radians(azimuth_degrees), math.radians(elevation_degrees)
        towards_eye = (math.cos(e) * math.sin(a), -math.cos(e) * math.cos(a), math.sin(e))
        right = (math.cos(a), math.sin(a), 0.0)
        forward = tuple(-t for t in towards_eye)
        up = (
            right[1] * forward[2] - right[2] * forward[1],
            right[2] * forward[0] - right[0] * forward[2],
            right[0] * forward[1] - right[1] * forward[0],
        )
        camera.SetFocalPoint(0.0, 0.0, 0.0)
        camera.SetPosition(*[t * distance for t in towards_eye])
        camera.SetViewUp(*up)
        renderer.ResetCameraClippingRange()

    place(30.0)
    for _ in range(args.warm_up):
        window.Render()
        window.WaitForCompletion()
    milliseconds = []
    for frame in range(args.frames):
        place(30.0 + frame)
        start = time.perf_counter()
        window.Render()
        window.WaitForCompletion()
        milliseconds.append((time.perf_counter() - start) * 1e3)
        if frame == 0 and args.save:
            grab = vtk.vtkWindowToImageFilter()
            grab.SetInput(window)
            grab.ReadFrontBufferOff()
            writer = vtk.vtkPNGWriter()
            writer.SetFileName(args.save)
            writer.SetInputConnection(grab.GetOutputPort())
            writer.Write()
    milliseconds.sort()
    name = "unshaded" if args.unshaded else "shaded"
    renderer_name = window.ReportCapabilities().split("OpenGL renderer string:")[-1].splitlines()[0].strip()
    print(f"vtk renderer: {renderer_name} (VTK {vtk.vtkVersion.GetVTKVersion()})")
    print(
        f"vtk-{name}-{width}x{height}: median {milliseconds[len(milliseconds) // 2]:.1f} ms over "
        f"{args.frames} frames (min {milliseconds[0]:.1f}, max {milliseconds[-1]:.1f})"
    )


if __name__ == "__main__":
    main()
