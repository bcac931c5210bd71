#!/usr/bin/env python3
"""Peer for the contact benchmark: the bouncing ball in Siconos' own kernel (Debian's
python3-siconos), MoreauJeanOSI(θ) with its LCP, m = 1, dropped from 1 m, g = 9.81, e = 0.9.

    siconos_kernel_ball.py STEP END THETA [--history FILE.csv EVERY]

Prints one line: `steps=N seconds=S us_per_step=U final_z=Z` (time of the step loop only,
Python loop included, as the peer is normally used). With --history, also writes time, z, vz
every EVERY steps with 17 digits (tests/data/siconos_kernel_ball.csv was made this way).
Exits 3 if siconos is not importable.
"""
import sys
import time

try:
    import numpy as np
    import siconos.kernel as sk
except ImportError as e:  # pragma: no cover
    print(
        f"siconos_kernel_ball: python3-siconos is not installed ({e}); apt-get install python3-siconos", file=sys.stderr
    )
    sys.exit(3)


def main() -> int:
    h, end, theta = (float(a) for a in sys.argv[1:4])
    history, every = None, 1
    if len(sys.argv) == 7 and sys.argv[4] == "--history":
        history, every = open(sys.argv[5], "w"), int(sys.argv[6])
        history.write("time,z,vz\n0,1,0\n")
    ball = sk.LagrangianLinearTIDS([1.0], [0.0], np.eye(1))
    ball.setFExtPtr(np.array([-9.81]))
    nslaw = sk.NewtonImpactNSL(0.9)
    relation = sk.LagrangianLinearTIR(np.eye(1))
    inter = sk.Interaction(nslaw, relation)
    nsds = sk.NonSmoothDynamicalSystem(0.0, end)
    nsds.insertDynamicalSystem(ball)
    nsds.link(inter, ball)
    osi = sk.MoreauJeanOSI(theta)
    td = sk.TimeDiscretisation(0.0, h)
    lcp = sk.LCP()
    sim = sk.TimeStepping(nsds, td, osi, lcp)
    steps = 0
    start = time.perf_counter()
    while sim.hasNextEvent():
        sim.computeOneStep()
        steps += 1
        if history is not None and steps % every == 0:
            history.write(f"{sim.nextTime():.17g},{ball.q()[0]:.17g},{ball.velocity()[0]:.17g}\n")
        sim.nextStep()
    seconds = time.perf_counter() - start
    print(f"steps={steps} seconds={seconds:.6f} us_per_step={1e6 * seconds / steps:.4f} final_z={ball.q()[0]:.6e}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
