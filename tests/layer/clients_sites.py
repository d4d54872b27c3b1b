"""glmark2's texture scene through zink with per-site and per-draw counts
(an application spec's "sites": true), captured by the daemon and read back
as a user reads it: /api/samples/{id}/sites and /draws, and `tally hotspots
RUN --by line` and `--by draw`. Relations from glmark2's source
(light-basic-tex.frag: one texture2D per fragment; the cube is one draw):

- the drawing pass's top line is the texture read, whose count is the
  pass's fragment invocations (one sample each), and whose bytes are the
  texture line's;
- each counted line's sites sum to the line (bytes);
- the pass's one draw holds all its counted lines' bytes;
- `tally hotspots` ranks the same first line and draw.

zink's modules carry no line information: a site names its instruction and
its disassembly, not a source line (docs/layer.md, "A shipped application,
line by line and draw by draw")."""
import json
import os
import shutil
import subprocess
import time
from urllib.parse import quote

import clients_relations as relations
from clients_service import start_daemon

READ_TOKEN = "r3ad-0123456789abcdefghijklmnopqrstuv"


def hotspots(args, api, run_id, by):
    env = dict(os.environ, TALLY_TOKEN=READ_TOKEN)
    tally = os.path.join(os.path.abspath(args.build), "client", "tally")
    p = subprocess.run([tally, "--server", api.base, "--json", "hotspots", str(run_id), "--by", by, "--top", "3"],
                       env=env, capture_output=True, text=True, timeout=60)
    if p.returncode != 0:
        return None, "tally hotspots --by %s exited %d: %s" % (by, p.returncode, p.stderr[-2000:])
    return json.loads(p.stdout), ""


def check_sample(api, sample_id, failures):
    """The stored frame's drawing pass: its top line and its one draw."""
    sample = api.get("/api/samples/%d" % sample_id)
    passes = relations.drawn(sample)
    if not failures.check(len(passes) == 1, "%d passes draw, expected the cube's one" % len(passes)):
        return None
    p = passes[0]
    sites = api.get("/api/samples/%d/sites?pass=%s&limit=1000" % (sample_id, quote(p["name"])))["sites"]
    lines = {(r["name"], r["access"]): r for r in p["resources"] if r["source"] == "counter"}
    sums = {}
    for s in sites:
        sums[(s["resource"], s["access"])] = sums.get((s["resource"], s["access"]), 0) + s["bytes"]
    for key, line in lines.items():
        failures.check(abs(sums.get(key, 0) - line["bytes"]) <= 1e-6 * max(line["bytes"], 1),
                       "line %s: its sites sum to %s bytes, the line has %s" % (key, sums.get(key), line["bytes"]))
    top = max(sites, key=lambda s: s["bytes"]) if sites else None
    reads = relations.image_reads(p)
    failures.check(top is not None and len(reads) == 1 and top["resource"] == reads[0]["name"]
                   and top["access"] == "read" and top["count"] == p["fragment_invocations"]
                   and top["bytes"] == reads[0]["bytes"],
                   "top site %s, expected the one texture read of %s, %d fragment invocations" %
                   (top and (top["resource"], top["access"], top["count"]), [r["name"] for r in reads],
                    p["fragment_invocations"]))
    failures.check(top is not None and top["line"] is None and top["disassembly"] != "",
                   "zink's module has no line information: the top site should name its disassembly, got %r" %
                   ((top and (top["line"], top["disassembly"])),))
    draws = api.get("/api/samples/%d/draws?pass=%s" % (sample_id, quote(p["name"])))
    counted = sum(r["bytes"] for r in lines.values())
    failures.check(len(draws["draws"]) == 1 and not draws["rest"] and draws["draws"][0]["bytes"] == counted,
                   "draws %s, expected the cube's one draw of the pass's %s counted bytes" %
                   ([(d["name"], d["bytes"]) for d in draws["draws"]], counted))
    return p, top, draws["draws"][:1]


def check_hotspots(args, api, run_id, top, draws, failures):
    by_line, why = hotspots(args, api, run_id, "line")
    if not failures.check(by_line is not None, why):
        return
    first = by_line["passes"][0]["top"][0]["detail"] if by_line["passes"] else {}
    failures.check(first.get("resource") == top["resource"] and first.get("count") == top["count"]
                   and first.get("bytes") == top["bytes"],
                   "tally hotspots --by line: first %s, expected the site %s" %
                   ({k: first.get(k) for k in ("resource", "count", "bytes")}, top["resource"]))
    by_draw, why = hotspots(args, api, run_id, "draw")
    if not failures.check(by_draw is not None, why):
        return
    first = by_draw["passes"][0]["top"][0]["detail"] if by_draw["passes"] else {}
    failures.check(bool(draws) and first.get("name") == draws[0]["name"],
                   "tally hotspots --by draw: first %s, expected %s" % (first.get("name"), draws))


def run(args, tmp, spec, failures):
    os.chmod(tmp, 0o755)
    apps = os.path.join(tmp, "apps")
    os.mkdir(apps)
    spec["application"]["command"][0] = shutil.copy2(shutil.which("glmark2"), apps)
    spec["sites"] = True
    daemon, api = start_daemon(args, tmp, apps)
    try:
        for _ in range(100):
            try:
                api.get("/api/health")
                break
            except OSError:
                time.sleep(0.1)
        job = api.wait(api.post("/api/captures", spec)["id"])
        if failures.check(job["status"] == "done", "job %s: %s" % (job["status"], job.get("error"))):
            run_id = api.get("/api/runs?capture=%d" % job["id"])["runs"][0]["id"]
            samples = api.get("/api/runs/%d/samples" % run_id)["samples"]
            checked = []
            for s in samples:
                failures.prefix = "frame %d: " % s["camera"]["frame"]
                checked.append(check_sample(api, s["id"], failures))
            failures.prefix = ""
            # tally hotspots reads the run's first sample.
            if checked and checked[0] is not None:
                check_hotspots(args, api, run_id, checked[0][1], checked[0][2], failures)
    finally:
        daemon.terminate()
        daemon.wait(timeout=30)
    failures.finish("the texture read is the top line (its disassembly), = fragment invocations; sites sum to "
                    "lines; one draw holds the pass; tally hotspots agrees")
