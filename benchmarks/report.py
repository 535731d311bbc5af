"""The benchmark's targets, judged PASS/FAIL, and plain-text tables of every figure."""

from __future__ import annotations

from typing import Any

MB = 1e6  # [bytes]
EXAMPLE_TRACKS = ("segmented", "formula_student", "carolo_cup")
BIG, SMALL = "generated_6000x3000", "generated_1000x1000"

TARGETS = {  # issue 16
    "vs_carracing_v3": 90.0,  # [x] tinyrace steps/s over CarRacing-v3's
    "vs_envpool": 9.0,  # [x] tinyrace steps/s over EnvPool's (1 env, 1 thread)
    "reset_ratio": 2.0,  # [x] CarRacing-v3 reset time over tinyrace's: reset <= 0.5x
    "image_steps_per_s": 3000.0,  # [steps/s] image track, one 120x160 camera
    "vs_tinycarlo": 300.0,  # [x] one 120x160 camera over tinycarlo 1.1 on its own examples
    "size_tolerance": 0.20,  # 6000x3000 step-only steps/s within 20% of 1000x1000's
    "rss_image_factor": 3.0,  # peak RSS <= 3 x decoded image bytes + 80 MB
    "rss_allowance": 80 * MB,  # [bytes]
    "async_ratio": 1.6,  # [x] AsyncVectorEnv(2) env-steps/s over one env's, on 2 cores
    "one_process_8": 1.5,  # [x] 8 envs in one process, env-steps/s over one env's
}


def rss_target(image_bytes: int) -> float:
    """[bytes] the peak RSS allowed for an env holding an image of ``image_bytes``."""
    return TARGETS["rss_image_factor"] * image_bytes + TARGETS["rss_allowance"]


# -- targets ----------------------------------------------------------------------------------
def rate_of(entry: Any, key: str = "steps_per_s") -> float | None:
    return entry[key] if isinstance(entry, dict) and key in entry else None


def verdict(ok: bool | None) -> str:
    return "n/a" if ok is None else ("PASS" if ok else "FAIL")


def why_missing(entry: Any) -> str:
    return entry if isinstance(entry, str) else "unavailable (see the JSON)"


def ratio_row(label: str, a: Any, b: Any, target: float, key: str = "steps_per_s") -> list[str]:
    """Row for ``a / b`` of two timings against ``>= target``."""
    ra, rb = rate_of(a, key), rate_of(b, key)
    if ra is None or rb is None:
        return [label, why_missing(a if ra is None else b), f">= {target:g}x", "n/a"]
    value = f"{ra / rb:.2f}x ({ra:,.0f} vs {rb:,.0f} steps/s)"
    return [label, value, f">= {target:g}x", verdict(ra / rb >= target)]


def reset_row(reset: dict[str, Any]) -> list[str]:
    label = "reset: CarRacing-v3 time / tinyrace's"
    target = f">= {TARGETS['reset_ratio']:g}x"
    mine, theirs = reset.get("tinyrace"), reset.get("carracing_v3")
    if not (isinstance(mine, dict) and isinstance(theirs, dict)):
        return [label, why_missing(reset.get("error")), target, "n/a"]
    ratio = theirs["mean_ms"] / mine["mean_ms"]
    value = f"{ratio:.2f}x ({mine['mean_ms']:.1f} vs {theirs['mean_ms']:.1f} ms)"
    return [label, value, target, verdict(ratio >= TARGETS["reset_ratio"])]


def image_rows(image: dict[str, Any]) -> list[list[str]]:
    """1-camera steps/s per example track, and the big track against the small one."""
    floor, rows = TARGETS["image_steps_per_s"], []
    for name in EXAMPLE_TRACKS:
        entry = image.get(f"{name}_1cam")
        r = rate_of(entry)
        value = f"{r:,.0f} steps/s" if r is not None else why_missing(entry)
        ok = None if r is None else r >= floor
        rows.append([f"image track {name}, 1 camera", value, f">= {floor:g} steps/s", verdict(ok)])
    return [*rows, size_row(image.get(BIG), image.get(SMALL))]


def size_row(big: Any, small: Any) -> list[str]:
    """The 6000x3000 track's steps/s against the 1000x1000 one's, reset time left out.

    The car leaves a small image sooner, so it resets more often: resets would blur
    what the target is about, a step's cost not growing with the image.
    """
    label, tolerance = "image 6000x3000 vs 1000x1000 (w/o resets)", TARGETS["size_tolerance"]
    target = f"within {tolerance:.0%}"
    rb, rs = rate_of(big, "step_only_per_s"), rate_of(small, "step_only_per_s")
    if rb is None or rs is None:
        return [label, why_missing(big if rb is None else small), target, "n/a"]
    value = f"{rb / rs:.2f}x ({rb:,.0f} vs {rs:,.0f} steps/s)"
    return [label, value, target, verdict(abs(rb / rs - 1.0) <= tolerance)]


def rss_row(rss: dict[str, Any]) -> list[str]:
    label = "peak RSS, 6000x3000 image track"
    peak, image_bytes = rss.get(BIG), rss.get(f"{BIG}_image_bytes")
    if image_bytes is None:
        return [label, why_missing(rss.get("error")), "n/a", "n/a"]
    target = rss_target(image_bytes)
    target_text = f"<= {target / MB:.0f} MB (3 x {image_bytes / MB:.0f} MB + 80 MB)"
    if not isinstance(peak, dict):
        return [label, why_missing(peak), target_text, "n/a"]
    value = peak["ru_maxrss"]
    return [label, f"{value / MB:.0f} MB", target_text, verdict(value <= target)]


def target_rows(results: dict[str, Any]) -> list[list[str]]:
    """One row per target: measure, value, target, PASS/FAIL/n/a."""
    speed, vector = results["throughput"], results["vector"]
    tinyrace = speed.get("tinyrace")
    return [
        ratio_row(
            "tinyrace vs CarRacing-v3",
            tinyrace,
            speed.get("carracing_v3"),
            TARGETS["vs_carracing_v3"],
        ),
        ratio_row(
            "tinyrace vs EnvPool (1 env, 1 thread)",
            tinyrace,
            speed.get("envpool"),
            TARGETS["vs_envpool"],
        ),
        reset_row(results["reset"]),
        *image_rows(results["image_tracks"]),
        rss_row(results["rss"]),
        ratio_row(
            "AsyncVectorEnv(2) vs one env",
            vector.get("async_2"),
            vector.get("single"),
            TARGETS["async_ratio"],
        ),
    ]


# -- figures ----------------------------------------------------------------------------------
def step_rows(results: dict[str, Any]) -> list[list[str]]:
    """Every timing: section, case, steps/s with and without resets, round spread, resets."""
    rows = []
    for section in ("throughput", "image_tracks", "vector", "vector_ceiling"):
        for name, entry in results[section].items():
            if rate_of(entry) is None:
                rows.append([section, name, why_missing(entry), "", "", "", ""])
                continue
            resets = entry["resets"]
            reset_ms = f"{entry['reset_seconds'] / resets * 1e3:.1f}" if resets else ""
            rate, step_rate = entry["steps_per_s"], entry["step_only_per_s"]
            spread = (max(entry["rounds"]) - min(entry["rounds"])) / 2 / rate
            rates = f"{rate:,.0f}", f"{step_rate:,.0f}", f"±{spread:.0%}"
            rows.append([section, name, *rates, str(resets), reset_ms])
    return rows


def memory_rows(rss: dict[str, Any]) -> list[list[str]]:
    """Every RSS figure: kind, ru_maxrss, VmHWM, over the imports-only baseline."""
    base = rss.get("baseline_imports")
    rows = []
    for name, peak in rss.items():
        if name.endswith("_bytes"):
            continue
        if not isinstance(peak, dict):
            rows.append([name, why_missing(peak), "", ""])
            continue
        extra = (
            f"{(peak['ru_maxrss'] - base['ru_maxrss']) / MB:+.0f}" if isinstance(base, dict) else ""
        )
        rows.append([name, f"{peak['ru_maxrss'] / MB:.0f}", f"{peak['vm_hwm'] / MB:.0f}", extra])
    return rows


def print_table(title: str, headers: list[str], rows: list[list[str]], width: int = 80) -> None:
    """A plain-text table; cells longer than ``width`` are cut (the JSON keeps them whole)."""
    cells = [[c if len(c) <= width else c[: width - 3] + "..." for c in row] for row in rows]
    widths = [max(len(r[i]) for r in [headers, *cells]) for i in range(len(headers))]
    print(f"\n{title}")
    print("  ".join(h.ljust(w) for h, w in zip(headers, widths, strict=True)).rstrip())
    print("  ".join("-" * w for w in widths))
    for row in cells:
        print("  ".join(c.ljust(w) for c, w in zip(row, widths, strict=True)).rstrip())


def report(results: dict[str, Any], rss_steps: int) -> None:
    """Print the targets, then the figures behind them."""
    m = results["machine"]
    print(f"\ntinyrace benchmark  {m['time']}  git {m['git']}  python {m['python']}")
    load = ", ".join(f"{x:.1f}" for x in m["load_average"])
    print(
        f"{m['processor']}, {m['usable_cpus']} usable CPUs, load {load} at start; {m['platform']}"
    )
    print_table("Targets", ["measure", "value", "target", "result"], target_rows(results))
    print_table(
        "Steps: seeded random actions, an observation every step, resets inside the timing",
        ["section", "case", "steps/s", "w/o resets", "rounds", "resets", "ms/reset"],
        step_rows(results),
    )
    reset = results["reset"]
    print_table(
        "Seeded resets",
        ["env", "mean ms", "median ms"],
        [
            [name, f"{r['mean_ms']:.2f}", f"{r['median_ms']:.2f}"]
            for name, r in reset.items()
            if isinstance(r, dict)
        ],
    )
    print_table(
        f"Peak RSS after make, reset and {rss_steps} steps, each in a fresh process [MB]",
        ["kind", "ru_maxrss", "VmHWM", "over baseline"],
        memory_rows(results["rss"]),
    )
