"""Track sources: each turns the config's ``track`` sections into read-only ``Track`` data.

The contract is in ``tracks/base.py``; the sources by ``track.type`` are listed in
``tracks/registry.py``. The sources in metres share ``polyline`` (closed-loop geometry),
``csv_rows`` (delimited text read with line and column numbers for errors) and
``circuit`` (a closed road with widths and tiles); their readers are ``centerline_csv``,
``cone_map`` and ``ros_map``.
"""
