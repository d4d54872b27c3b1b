#!/usr/bin/env python3
"""Footprint beside requested bytes in a capture result (tests/gpu/footprint.sh).

Per resolution and renderer: requested and footprint bytes per frame (mean
over the cameras), their ratio to deferred, and the reuse factor; then per
pass the achieved bandwidth of both against the device's measured ceiling.
"""
import json
import statistics
import sys
from collections import defaultdict


def mean(values):
    return statistics.mean(values) if values else float("nan")


def main(path):
    result = json.load(open(path))
    runs = result["runs"]
    device = result.get("device", {})
    ceilings = device.get("ceilings") or {}
    bw = ceilings.get("bandwidth_bytes_per_s")
    ops = ceilings.get("arithmetic_ops_per_s")
    print(f"device: {device.get('name')}  driver {device.get('driver_info', device.get('driver', ''))}")
    if bw:
        print(f"ceilings: streaming copy {bw / 1e9:.0f} GB/s, FMA {ops / 1e12:.1f} Tops/s "
              f"(copy of {ceilings.get('copy_bytes', 0) / 2**20:.0f} MiB)")
    by_res = defaultdict(dict)
    # Reads of images (textures, attachments, depth), reads of buffers, writes: requested and footprint.
    split = defaultdict(lambda: defaultdict(lambda: defaultdict(list)))
    passes = defaultdict(lambda: defaultdict(lambda: defaultdict(list)))
    for run in runs:
        res = f"{run['width']}x{run['height']}"
        samples = run["samples"]
        req = mean([s["bytes"] for s in samples])
        fp = mean([s.get("footprint_bytes", float("nan")) for s in samples])
        ms = mean([s["frame_ms"] for s in samples])
        ms_i = mean([s["frame_ms_instrumented"] for s in samples])
        by_res[res][run["renderer"]] = (req, fp, ms, ms_i)
        for s in samples:
            cats = defaultdict(lambda: [0.0, 0.0])
            for p in s["passes"]:
                for line in p["resources"]:
                    if line["access"] == "write":
                        cat = "written"
                    elif line.get("kind") in ("texture", "attachment", "depth"):
                        cat = "image read"
                    else:
                        cat = "buffer read"
                    cats[cat][0] += line["bytes"]
                    cats[cat][1] += line.get("footprint_bytes") or 0.0
            for cat, (b, f) in cats.items():
                split[res][run["renderer"]][cat].append((b, f))
            for p in s["passes"]:
                roof = p.get("roofline") or {}
                d = passes[res][run["renderer"]]
                d[p["name"]].append((p.get("bytes", 0), p.get("footprint_bytes"), p.get("gpu_ms", 0),
                                     roof.get("fraction_of_peak_bandwidth"),
                                     roof.get("fraction_of_peak_bandwidth_footprint"),
                                     roof.get("intensity_footprint")))
    for res, rows in by_res.items():
        base = rows.get("deferred")
        print(f"\n{res}: per frame, mean over cameras (ratios against deferred)")
        print(f"{'renderer':<18}{'requested':>12}{'x':>7}{'footprint':>12}{'x':>7}{'reuse':>8}{'frame ms':>10}{'instr. x':>9}")
        for name, (req, fp, ms, ms_i) in rows.items():
            rx = req / base[0] if base else float("nan")
            fx = fp / base[1] if base and base[1] else float("nan")
            print(f"{name:<18}{req / 1e9:>10.3f}GB{rx:>7.2f}{fp / 1e6:>10.1f}MB{fx:>7.2f}{req / fp if fp else float('nan'):>8.0f}"
                  f"{ms:>10.3f}{ms_i / ms if ms else float('nan'):>9.2f}")
        print(f"\n{res}: reads and writes per frame, requested / footprint (MB), ratio against deferred")
        cats = ["image read", "buffer read", "written"]
        print(f"{'renderer':<18}" + "".join(f"{c + ' req':>16}{'x':>6}{c + ' fp':>15}{'x':>6}" for c in cats))
        def avg(renderer, cat, k):
            return mean([v[k] for v in split[res][renderer][cat]])
        for name in rows:
            cells = ""
            for c in cats:
                b, f = avg(name, c, 0), avg(name, c, 1)
                bd, fd = avg("deferred", c, 0), avg("deferred", c, 1)
                cells += f"{b / 1e6:>16.1f}{b / bd if bd else float('nan'):>6.2f}{f / 1e6:>15.2f}{f / fd if fd else float('nan'):>6.2f}"
            print(f"{name:<18}{cells}")
        print(f"\n{res}: per pass, mean over cameras: bandwidth achieved (GB/s) and fraction of the copy ceiling")
        print(f"{'renderer':<18}{'pass':<14}{'gpu ms':>8}{'requested':>11}{'frac':>8}{'footprint':>11}{'frac':>8}{'ops/B(fp)':>11}")
        for name, ps in passes[res].items():
            for pname, vals in ps.items():
                b = mean([v[0] for v in vals])
                f = mean([v[1] for v in vals if v[1] is not None])
                t = mean([v[2] for v in vals])
                fr = mean([v[3] for v in vals if v[3] is not None])
                ff = mean([v[4] for v in vals if v[4] is not None])
                it = mean([v[5] for v in vals if v[5] is not None])
                gbs = b / (t * 1e-3) / 1e9 if t else float("nan")
                fgbs = f / (t * 1e-3) / 1e9 if t else float("nan")
                print(f"{name:<18}{pname:<14}{t:>8.3f}{gbs:>11.1f}{fr:>8.3f}{fgbs:>11.1f}{ff:>8.4f}{it:>11.2f}")


if __name__ == "__main__":
    main(sys.argv[1])
