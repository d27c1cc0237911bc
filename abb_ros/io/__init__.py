"""File and wire formats, one room each.

rosbag2 MCAP bags (bag/), CDR and message definitions (wire/), the Foxglove WebSocket live
view (live_view/), drive, scenario and map files (files/).
"""
