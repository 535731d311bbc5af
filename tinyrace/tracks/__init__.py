"""Track sources in metres: readers of real-world formats and the geometry they share.

``polyline`` holds closed-loop geometry (arc length, resampling, headings, edges,
tiles, self-intersection); ``csv_rows`` reads delimited text with line and column
numbers for errors; ``centerline_csv``, ``cone_map`` and ``ros_map`` read the
racetrack-database centreline CSV, the Formula Student cone map and the ROS
map_server map. World frame: metres, x right, y up, headings counter-clockwise
from +x.
"""
