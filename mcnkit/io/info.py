"""What a robot log holds, as ``mcnkit info`` shows it: :func:`describe` (a JSON-ready dict) and
:func:`print_info` (the text)."""

from __future__ import annotations

import math
from datetime import UTC, datetime
from typing import TYPE_CHECKING, Any

from mcnkit.io.plausible import MAX_RANGE_M

if TYPE_CHECKING:
    from mcnkit.io.base import LogReader

__all__ = ["describe", "print_info"]


def describe(log: LogReader) -> dict[str, object]:
    """Everything ``mcnkit info`` prints, as a JSON-ready dict."""
    start, end = log.time_range_ns()
    info: dict[str, object] = {
        "path": str(log.path),
        "format": log.format,
        "compression": log.compression,
        "start_ns": start,
        "end_ns": end,
        "duration_s": round((end - start) / 1e9, 3),
        "topics": [{"name": t.name, "type": t.msgtype, "count": t.count} for t in log.topics],
        "scan_topic": log.scan_topic or None,
        "odom_source": log.odom_source or None,
        "lidar_only": log.lidar_only,
    }
    if log.scan_topic:
        spec = log.lidar_spec
        info["scans"] = next((t.count for t in log.topics if t.name == log.scan_topic), 0)
        if log.laser_lines is not None:
            info["laser_lines"] = log.laser_lines
        info["scanner"] = {
            "beams": spec.n_beams,
            "fov_deg": round(math.degrees(spec.fov_rad), 3),
            "angle_min_deg": round(math.degrees(spec.angle_min_rad), 3),
            "angle_increment_deg": round(math.degrees(spec.angle_increment_rad), 4),
            "range_min_m": round(spec.range_min_m, 3),
            "range_max_m": round(spec.range_max_m, 3),
            "range_max_stated": spec.range_max_m < MAX_RANGE_M,  # False: the log states none (see BagLog)
            "base_to_laser": [spec.base_to_laser.x_m, spec.base_to_laser.y_m, spec.base_to_laser.yaw_rad],
            "sweep_s": round(float(spec.beam_times_s.max()), 6),
        }
    return info


def _stamp_text(ns: int) -> str:
    if ns > 10**17:  # absolute (epoch) time
        return datetime.fromtimestamp(ns / 1e9, tz=UTC).isoformat(timespec="milliseconds")
    return f"{ns / 1e9:.3f} s (relative)"


def print_info(info: dict[str, Any]) -> None:
    """Prints :func:`describe`'s dict as ``mcnkit info`` shows it."""
    print(f"file      {info['path']}")
    print(f"format    {info['format']}" + (f", compressed: {info['compression']}" if info.get("compression") else ""))
    print(f"start     {_stamp_text(info['start_ns'])}")
    print(f"end       {_stamp_text(info['end_ns'])}")
    print(f"duration  {info['duration_s']:.3f} s")
    print("topics")
    width = max([len(t["name"]) for t in info["topics"]] + [5])
    for t in info["topics"]:
        print(f"  {t['name']:<{width}}  {t['count']:>7}  {t['type']}")
    print(f"scan      {info['scan_topic'] or 'none (no sensor_msgs/LaserScan or MultiEchoLaserScan topic)'}")
    if not info["odom_source"]:
        print("odometry  no odometry: lidar-only (no Odometry topic, no odom->base transform)")
    elif info["lidar_only"]:
        print(f"odometry  {info['odom_source']}, ignored: lidar-only")
    else:
        print(f"odometry  {info['odom_source']}")
    if "scanner" in info:
        s = info["scanner"]
        read = f" (read from {info['laser_lines']} laser lines)" if "laser_lines" in info else ""
        mount = s["base_to_laser"]
        reach = (f"range {s['range_min_m']}–{s['range_max_m']} m" if s.get("range_max_stated", True) else
                 f"range from {s['range_min_m']} m, no maximum stated (every finite reading up to "
                 f"{s['range_max_m']:g} m is a return)")
        print(f"scanner   {info['scans']} scans{read} of {s['beams']} beams, field of view {s['fov_deg']}° "
              f"(from {s['angle_min_deg']}° in {s['angle_increment_deg']}° steps), "
              f"{reach}, mount at ({mount[0]:.3f}, {mount[1]:.3f}) m, "
              f"turned {math.degrees(mount[2]):.1f}°"
              + (f", each sweep {s['sweep_s'] * 1e3:.1f} ms (deskewed by the SLAM)" if s["sweep_s"] else ""))
