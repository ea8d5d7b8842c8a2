"""Streams and what they carry: the layer every other one reads and writes through.

- :mod:`.schemas`: the stream kinds of ``schemas/`` (columns, units, roles), validation.
- :mod:`.header`: a stream's header (kind, schema, metadata) and its history lines.
- :mod:`.streams`: reading and writing Arrow IPC, Parquet, HDF5 (:mod:`.h5io`), files
  and pipes; :mod:`.files`: atomic named outputs and the overwrite rule.
- :mod:`.readings`: a readings stream's heads: geometry in field metadata, angles.
- :mod:`.curves`: deviations and spectrum tables as the methods return them.
- :mod:`.rig`: rig description files (TOML); :mod:`.info`: ``enc info``'s description.
- :mod:`.statistics`: p-p, +/-, mean, Bessel s and RMS, one convention for all.
- :mod:`.text`: metadata strings made safe to print (control characters escaped).
"""
