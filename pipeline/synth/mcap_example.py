"""The small example MCAP log: a lamp heating a plate, as a ROS 2 robot would log it.

``/lamp/cmd`` (``std_msgs/msg/Float64``, volts) is published at 1 Hz; ``/plate/temp``
(``plant_msgs/msg/PlateTemperature``: a header and a ``temperature`` measurement with
``value`` and ``variance``) at 2 Hz with a jittered sample clock and 5-15 ms logging
latency. The plant is first order with dead time, ``K = 4 degC/V``, ``T = 20 s``,
``delay = 3 s``; the lamp steps 2.0 -> 5.0 V at 30 s and 5.0 -> 3.5 V at 160 s, from a
plate settled at 35 degC. Deterministic (seeded): ``datasets/examples/lamp_plate.mcap`` is
this function's output, regenerated with ``python -m pipeline.synth.mcap_example``.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
from mcap_ros2.writer import Writer

from ..models import ProcessModel
from .plants import staircase

EXAMPLE = {
    "input": ("/lamp/cmd", "data"), "output": ("/plate/temp", "temperature.value"),
    "u0": 2.0, "y0": 35.0, "steps": [(30.0, 5.0), (160.0, 3.5)], "t_end": 300.0,
    "K": 4.0, "T": 20.0, "delay": 3.0, "noise": 0.05, "start_ns": 1_700_000_000_000_000_000,
}

PLATE_TEMPERATURE = """std_msgs/Header header
plant_msgs/Measurement temperature
================================================================================
MSG: std_msgs/Header
builtin_interfaces/Time stamp
string frame_id
================================================================================
MSG: plant_msgs/Measurement
float64 value
float64 variance
"""


def _output(t: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Exact plate temperature at the (irregular) times ``t``, plus sensor noise."""
    e = EXAMPLE
    model = ProcessModel("first_order", {"K": e["K"], "T": e["T"], "delay": e["delay"]})
    y = np.full(t.size, e["y0"])
    level = e["u0"]
    for t_step, new in e["steps"]:
        y += (new - level) * model.unit_step(t - t_step)
        level = new
    return y + rng.normal(0.0, e["noise"], t.size)


def _stamp(t_ns: int) -> dict:
    return {"stamp": {"sec": t_ns // 10**9, "nanosec": t_ns % 10**9}, "frame_id": "plate"}


def example_messages() -> list[tuple[int, str, dict]]:
    """(log time ns, topic, message) of the example, in log-time order."""
    e = EXAMPLE
    rng = np.random.default_rng(2024)
    t_in = np.arange(0.0, e["t_end"] + 1e-9, 1.0)
    u_in = staircase(t_in, e["u0"], e["steps"])
    t_out = np.arange(0.0, e["t_end"] + 1e-9, 0.5) + rng.uniform(-0.01, 0.01, 601)
    t_out[0] = 0.0
    y_out = _output(t_out, rng)
    latency = rng.integers(5_000_000, 15_000_000, t_out.size)
    ns = lambda t: e["start_ns"] + int(round(t * 1e9))  # noqa: E731
    msgs = [(ns(t), "/lamp/cmd", {"data": float(u)}) for t, u in zip(t_in, u_in, strict=True)]
    msgs += [(ns(t) + int(lat), "/plate/temp",
              {"header": _stamp(ns(t)), "temperature": {"value": round(float(y), 3),
                                                        "variance": e["noise"] ** 2}})
             for t, y, lat in zip(t_out, y_out, latency, strict=True)]
    return sorted(msgs, key=lambda m: m[0])


def write_example_mcap(path: str | Path) -> Path:
    """Write the example log to ``path`` (about 900 messages, well under 100 kB)."""
    path = Path(path)
    with open(path, "wb") as f:
        writer = Writer(f)
        schemas = {
            "/lamp/cmd": writer.register_msgdef("std_msgs/msg/Float64", "float64 data"),
            "/plate/temp": writer.register_msgdef("plant_msgs/msg/PlateTemperature",
                                                  PLATE_TEMPERATURE),
        }
        for log_time, topic, msg in example_messages():
            writer.write_message(topic, schemas[topic], msg, log_time=log_time)
        writer.finish()
    return path


if __name__ == "__main__":
    target = sys.argv[1] if len(sys.argv) > 1 else "datasets/examples/lamp_plate.mcap"
    Path(target).parent.mkdir(parents=True, exist_ok=True)
    print(write_example_mcap(target), Path(target).stat().st_size, "bytes")
