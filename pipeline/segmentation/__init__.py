"""Segmentation: the step and impulse events of a record, and how the output responds to
each (settling, a ramp, a level shift), from any operating point, in noise.

- :mod:`.detect` - :func:`segment`: the input's changes found and classified, each
  event's window, levels, noise and response; :func:`event_data` on plain arrays;
- :mod:`.edges` - the scan for the input's edges, linear in samples and events;
- :mod:`.magnitudes` - extreme signal magnitudes scaled before the scan.
"""

from .detect import SegmentOptions, event_data, segment

__all__ = ["SegmentOptions", "event_data", "segment"]
