"""What each command prints for a person (its --json prints the result dict instead)."""

from __future__ import annotations

from pathlib import Path
from typing import Any


def calibrate_lines(folder: str, r: dict[str, Any]) -> list[str]:
    lines = [f"{folder}: board in frame {r['frame']}: {r['corners']} corners, reprojection "
             f"error {r['reprojection_error_px']:.3f} px",
             f"  camera at {r['camera_position_m']} m in W -> {r['camera_yaml']}"]
    if "intrinsics_rms_px" in r:
        lines.insert(0, f"{folder}: intrinsics from {r['views_used']} board images, RMS "
                     f"{r['intrinsics_rms_px']:.3f} px")
    if "palm_toml" in r:
        lines.append(f"  palm model -> {r['palm_toml']} (link residuals "
                     f"{r['palm_link_residual_cm']} cm)")
    return lines


def detect_lines(folder: str, r: dict[str, Any]) -> list[str]:
    if r["kind"] == "patch":
        line = (f"{folder}: patch found in {r['ok_frames']} of {r['frames']} frames, "
                f"{r['lost_spans']} losses (longest {r['longest_loss_s']} s)")
    else:
        line = f"{folder}: {r['blobs']} candidate blobs in {r['frames']} frames"
    s = r.get("kernel_setup_s", 0) + r.get("decoder_setup_s", 0)  # what frames/s leaves out
    return [line + f", {r['frames_per_s']:.0f} frames/s -> {r['detections']}"] + (
        [f"  (detection alone; its compiled kernel and the decoder took {s:.1f} s to set up "
         "first)"] if s >= 0.05 else [])


def fuse_lines(folder: str, r: dict[str, Any]) -> list[str]:
    guards = ", ".join(f"{r[k]} {k.replace('_frames', '')}" for k in
                       ("gated_frames", "reacquired", "reseeded") if r.get(k))
    return [f"{folder}: {r['method']}: {r['frames']} frames ({r['detections_used']} with a "
            f"detection{'; ' + guards if guards else ''}), {r['frames_per_s']:.0f} frames/s "
            f"-> {r['trajectory']}"] + _setup(r) + (
        [f"  initialised from {r['initialised_from']}: residual {r['init_residual_px']} px, "
         f"{r['init_residual_mm']} mm"] if "init_residual_px" in r else []) + (
        ["  arm " + arm_estimate_line(r["arm_auto"])] if r.get("arm_auto") else []) + _imu_offset(r)


def _setup(r: dict[str, Any]) -> list[str]:
    """What frames/s leaves out: the compiled kernel's one-time set-up in this process."""
    s = r.get("kernel_setup_s", 0)
    return [f"  (the filter alone; its compiled kernel took {s:.1f} s to set up first)"] \
        if s >= 0.05 else []


def _imu_offset(r: dict[str, Any]) -> list[str]:
    """The IMU's clock offset: estimated ("auto") or declared and checked."""
    o = r.get("imu_offset_s")
    if not o:
        return []
    if o["from"] == "auto":
        return [f"  IMU offset {o['value']:+.3f} ± {o['sd']:.3f} s (estimated from the data)"]
    seen = f"; the data say {o['estimate']:+.3f} ± {o['sd']:.3f} s" if "estimate" in o else ""
    return [f"  IMU offset {o['value']:+.3f} s (declared{seen})"]


def compare_summary(r: dict[str, Any]) -> dict[str, Any]:
    """compare's --json: its result without the rows and the printed table, with the 3-D
    accuracy of each method and joint (errors.accuracy_3d)."""
    from armtrack_cli.compare.errors import accuracy_3d

    return {**{k: v for k, v in r.items() if k not in ("rows", "table")},
            "accuracy_3d": accuracy_3d(r["rows"])}


def compare_lines(folder: str, r: dict[str, Any]) -> list[str]:
    excl = {k: v for k, v in r["excluded_frames"].items() if v}
    lines = [f"{folder}:", r["table"]]
    if excl:
        lines.append("frames without ground truth (gaps), excluded: " +
                     ", ".join(f"{k} {v}" for k, v in excl.items()))
    lines.append(f"-> {r['errors']}, {r['measures']}")
    return lines


def run_lines(folder: str, r: dict[str, Any]) -> list[str]:
    done = [f"{name} {state}" for name, state in r["stages"].items()]
    return [f"{folder}: " + "; ".join(done) + f" -> {r['out']}"]


def simulate_lines(r: dict[str, Any]) -> list[str]:
    extra = (f"{r['imu_samples']} IMU samples" if "imu_samples" in r else
             f"{r['depth_frames']} depth frames")
    return [f"wrote {r['session']} ({r['frames']} frames, {extra}, {r['qualisys_frames']} "
            f"Qualisys frames) and {r['truth']}"]


def info_text(info: dict[str, Any]) -> str:
    """The human-readable report printed by `armtrack info`."""
    s = info["session"]
    lines = [f"session {s['id']}  ({s['kind']} session, {s['side']} side"
             + (f", task {s['task']}" if s["task"] else "") + ")", f"  folder  {s['folder']}"]
    lines += _imu(info) + _camera(info) + _models(info) + _groundtruth(info)
    lines.append("methods")
    for name, state in info["methods"].items():
        lines.append(f"  {name:<14}{state}")
    return "\n".join(lines)


def _imu(info) -> list[str]:
    if "imu" not in info:
        return []
    i = info["imu"]
    lines = [f"imu       {Path(i['file']).name}  [{i['format']}]  {i['samples']} samples at "
             f"{i['rate_hz']:g} Hz, {i['duration_s']:.2f} s",
             f"          session span {_span(i['span_s'])}; dropped samples "
             f"{i['dropped_samples']} in {i['gaps']} gaps (largest {i['largest_gap_s']} s)",
             f"          orientation: {i['orientation']}; forearm axis {i['forearm_axis']}"]
    if "offset_s" in i:
        o = i["offset_s"]
        lines.append("          clock offset " + (
            f"{o['value']:+.3f} ± {o['sd']:.3f} s (auto, estimated at the last fuse)"
            if isinstance(o, dict) else o if isinstance(o, str) else f"{o:+.3f} s (declared)"))
    lines += [f"          warning: {ch} has no data" for ch in i["empty_channels"]]
    return lines + [f"          note: {n}" for n in i["notes"]]


def _camera(info) -> list[str]:
    lines = []
    if "video" in info:
        v = info["video"]
        lines.append(f"video     {Path(v['file']).name}  {v['frames']} frames {v['width']}x"
                     f"{v['height']} at {v['fps']:g} fps, {v['duration_s']:.2f} s "
                     f"(times from {v['times_from']})")
    if "depth" in info:
        lines.append(f"depth     {info['depth']['frames']} frames in depth/")
    if "intrinsics" in info:
        k = info["intrinsics"]
        lines.append(f"camera    {k['board_images']} board images in calib/" if "folder" in k else
                     f"camera    fx {k['fx']:.1f} fy {k['fy']:.1f} cx {k['cx']:.1f} cy {k['cy']:.1f}"
                     f", {k['size'][0]}x{k['size'][1]}")
    if "board" in info:
        b = info["board"]
        lines.append(f"board     {b['type']} {b['squares'][0]}x{b['squares'][1]} squares of "
                     f"{b['square_m'] * 100:g} cm, {b['dictionary']}")
    return lines


def arm_estimate_line(e: dict[str, Any]) -> str:
    """The arm fuse estimated for "auto", ± 1 SD, in cm."""
    sh = ", ".join(f"{v * 100:.1f}±{d * 100:.1f}" for v, d in zip(e["shoulder_m"],
                                                              e["shoulder_sd_m"]))
    return (f"estimated ({', '.join(e['estimated'])} from {e['from_s']:g}-{e['to_s']:g} s): "
            f"shoulder [{sh}] cm, L1 {e['upper_arm_m'] * 100:.1f}±{e['upper_arm_sd_m'] * 100:.1f} "
            f"cm, L2 {e['forearm_m'] * 100:.1f}±{e['forearm_sd_m'] * 100:.1f} cm"
            + ("; refined over the whole session by the arm smoother" if "refined_by" in e else ""))


def _models(info) -> list[str]:
    lines = []
    if "arm" in info:
        a = info["arm"]
        def m(v):
            return '"auto"' if v == "auto" else f"{v} m"
        lines.append(f"arm       L1 {m(a['upper_arm_m'])}, L2 {m(a['forearm_m'])}, shoulder "
                     f"{m(a['shoulder_m'])}" + ("" if a["shoulder_m"] == "auto" else " in W"))
        if a.get("estimate"):
            lines.append("          " + arm_estimate_line(a["estimate"]))
        elif "estimate" in a:
            lines.append("          (\"auto\": estimated by `armtrack fuse`, not run yet)")
    if "palm" in info:
        lines.append(f"palm      markers {', '.join(info['palm']['markers'])}")
    return lines


def _groundtruth(info) -> list[str]:
    if "groundtruth" not in info:
        return []
    g = info["groundtruth"]
    lines = [f"qualisys  {Path(g['file']).name}  {g['frames']} frames at {g['rate_hz']:g} Hz, "
             f"{g['duration_s']:.2f} s; session span {_span(g['span_s'])}",
             "          markers missing: " + ", ".join(f"{k} {v:g}%"
                                                      for k, v in g["missing_pct"].items())]
    lines += [f"          missing: {p}" for p in g.get("problems", [])]
    if "reach" in g:
        r = g["reach"]
        lines.append(f"          wrist {r['wrist_distance_m'][0]}-{r['wrist_distance_m'][1]} m "
                     f"from the shoulder (reach {r['reach_m']} m)")
    return lines


def _span(span) -> str:
    return span if isinstance(span, str) else f"{span[0]:.3f} … {span[1]:.3f} s"
