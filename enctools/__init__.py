"""enctools: calibration of angle encoders and precision rotary tables.

The library behind the ``enc`` commands: stream I/O (:mod:`enctools.streams`),
stream kinds (:mod:`enctools.schemas`), rig descriptions (:mod:`enctools.rig`),
the virtual rig and hardware backends (:mod:`enctools.hw`), acquisition
(:mod:`enctools.acquire`) and the measurement methods.
"""

__version__ = "0.1.0"
