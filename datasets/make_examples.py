"""Write the small example logs the project generates itself (committed beside this file).

    python datasets/make_examples.py

- ``examples/jakoubek/system{1..5}.csv``: Jakoubek's five systems (seed 002 eqs. 26-30,
  gain 2) stepped 1 -> 2 at t = 3 s from y0 = 5, noise-free, 10 ms sampling, 20 s after
  the step (the ISE horizon of ERRATA [S2] 23).
- ``examples/lamp_plate.mcap``: the ROS 2 MCAP example, a lamp heating a plate
  (:mod:`pipeline.synth.mcap_example`; also ``python -m pipeline.synth.mcap_example``).
"""

from pathlib import Path

import polars as pl

from pipeline.synth import jakoubek_record
from pipeline.synth.mcap_example import write_example_mcap

HERE = Path(__file__).resolve().parent


def main() -> None:
    out = HERE / "examples" / "jakoubek"
    out.mkdir(parents=True, exist_ok=True)
    for system in range(1, 6):
        rec = jakoubek_record(system, dt=0.01, after=20.0)
        pl.DataFrame({"time": rec.t, "u": rec.u, "y": rec.y}).write_csv(
            out / f"system{system}.csv", float_precision=9)
        print(out / f"system{system}.csv")
    print(write_example_mcap(HERE / "examples" / "lamp_plate.mcap"))


if __name__ == "__main__":
    main()
