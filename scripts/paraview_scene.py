"""Renders a run's visual output with ParaView and saves a ParaView state for the GUI.

Usage (Debian's ParaView renders off screen only under an X server; xvfb-run gives it one):
    xvfb-run -a pvbatch scripts/paraview_scene.py OUT [--time T] [--size W H]

OUT is a run's output folder with visual output (output { visual { every: N } }): its
scene.pvd (a coupled run, every process) or visual.pvd (a single process). Writes into OUT:
  paraview/snapshot.png   the scene at time T (default: the last frame), in its own axis box;
  paraview/scene.pvsm     the same pipeline as a ParaView state: `paraview --state
                          OUT/paraview/scene.pvsm` opens it with the time slider over the run.
The pipeline splits the cells by their `kind` (docs/user-guide.md, "Seeing the run"): bodies, beams and
solids coloured by kind, hex27 solids by `von_mises` where present, contact nodes as points, stop
planes translucent and red while `in_contact`, coupling ties as lines.
"""
import argparse
import os
import sys

from paraview import simple as pv  # pvbatch / pvpython only

# VisualFrame cell kinds (interface/visual/visual_frame.h).
BODY_AXIS, BODY_SHAPE, BEAM_AXIS, BEAM_SECTION, SOLID, TIE, CONTACT_NODE, STOP_PLANE = range(8)


def arguments(argv):
    parser = argparse.ArgumentParser(prog="paraview_scene.py", description=__doc__.split("\n")[0])
    parser.add_argument("out", help="the run's output folder")
    parser.add_argument("--time", type=float, help="the snapshot's time [s] (default: the last frame)")
    parser.add_argument("--size", type=int, nargs=2, default=[1280, 800], metavar=("W", "H"))
    return parser.parse_args(argv)


def kinds(source, low, high):
    """The cells of source whose kind is in [low, high]."""
    t = pv.Threshold(Input=source, Scalars=["CELLS", "kind"])
    t.LowerThreshold, t.UpperThreshold = low, high
    return t


def main(argv):
    args = arguments(argv)
    pvd = next(
        (os.path.join(args.out, n) for n in ("scene.pvd", "visual.pvd") if os.path.isfile(os.path.join(args.out, n))),
        None,
    )
    if pvd is None:
        print(
            f"paraview_scene.py: error: {args.out} has no scene.pvd or visual.pvd; run with "
            f"--set output.visual.every=N first",
            file=sys.stderr,
        )
        return 2
    reader = pv.PVDReader(FileName=os.path.abspath(pvd))
    times = [float(t) for t in reader.TimestepValues] or [0.0]
    time = times[-1] if args.time is None else min(times, key=lambda t: abs(t - args.time))
    view = pv.CreateView("RenderView")
    view.ViewSize = list(args.size)
    view.Background = [1, 1, 1]
    view.OrientationAxesVisibility = 1
    try:  # ParaView 5.10+: a plain background instead of the palette's gradient
        view.UseColorPaletteForBackground = 0
    except AttributeError:
        pass

    structure = kinds(reader, BODY_AXIS, TIE)  # bodies, beams, solids and ties
    d = pv.Show(structure, view)
    pv.ColorBy(d, ("CELLS", "kind"))
    lut = pv.GetColorTransferFunction("kind")
    lut.ApplyPreset("Rainbow Uniform", True)
    lut.RescaleTransferFunction(BODY_AXIS, STOP_PLANE)
    d.LineWidth = 2.0
    nodes = kinds(reader, CONTACT_NODE, CONTACT_NODE)
    d = pv.Show(nodes, view)
    d.SetRepresentationType("Points")
    d.PointSize = 8.0
    d.RenderPointsAsSpheres = 1
    pv.ColorBy(d, ("CELLS", "in_contact"))
    planes = kinds(reader, STOP_PLANE, STOP_PLANE)
    d = pv.Show(planes, view)
    d.Opacity = 0.35
    pv.ColorBy(d, ("CELLS", "in_contact"))
    contact = pv.GetColorTransferFunction("in_contact")
    contact.RGBPoints = [0.0, 0.55, 0.55, 0.55, 1.0, 0.85, 0.1, 0.1]

    scene = pv.GetAnimationScene()
    scene.UpdateAnimationUsingDataTimeSteps()
    scene.AnimationTime = time
    view.ViewTime = time
    pv.Render(view)  # (the first render places a default camera: the view is set after it)
    view.CameraPosition = [1.0, -1.6, 0.9]
    view.CameraFocalPoint = [0.0, 0.0, 0.0]
    view.CameraViewUp = [0.0, 0.0, 1.0]
    view.ResetCamera()
    pv.SetActiveView(view)
    pv.GetActiveCamera().Dolly(1.5)
    folder = os.path.join(args.out, "paraview")
    os.makedirs(folder, exist_ok=True)
    png, state = os.path.join(folder, "snapshot.png"), os.path.join(folder, "scene.pvsm")
    pv.SaveScreenshot(png, view, ImageResolution=list(args.size))
    pv.SaveState(state)
    print(f"paraview_scene.py: {png} at t = {time:g} s ({len(times)} frames); state {state}")
    return 0


if __name__ == "__main__":
    code = main(sys.argv[1:])
    sys.stdout.flush()
    sys.stderr.flush()
    # Leave without VTK's teardown: under xvfb-run it fails on the GL context (GLXBadContext)
    # after the files are written, which would make a good run's exit code 1.
    os._exit(code)
