#!/usr/bin/python3
"""GET /metrics of a real tallyd, read by Debian's python3-prometheus-client
text parser (an independent reader of the format), and its figures moved by
real captures on lavapipe:

  - a capture done: tally_jobs_finished_total{status="done"} +1, one more
    tally_capture_duration_seconds observation, tally_jobs{state="done"} +1;
  - a queued job cancelled and a running one cancelled: cancelled +2;
  - every request this test made is counted under its route and code;
  - tally_device_info names the device the runs were stored with;
  - tally_build_info names the commit /api/health names;
  - the store's size on disk is the database file's size;
  - the daemon's log lines carry level= and job=.

  metrics_test.py TALLYD
"""
import json
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import time
import urllib.request

from prometheus_client.parser import text_string_to_metric_families

TALLYD = sys.argv[1]
failures = []


def check(ok, what):
    print(("ok: " if ok else "FAIL: ") + what)
    if not ok:
        failures.append(what)


class Daemon:
    def __init__(self, folder):
        self.folder = folder
        self.err = open(os.path.join(folder, "serve.err"), "w")
        self.out = os.path.join(folder, "serve.out")
        env = dict(os.environ, TMPDIR=folder)
        env.pop("JOURNAL_STREAM", None)
        self.proc = subprocess.Popen([TALLYD, "serve", "--db", os.path.join(folder, "tally.db"), "--port", "0"],
                                     stdout=open(self.out, "w"), stderr=self.err, env=env)
        self.url = None
        for _ in range(1200):  # a minute at most: polls end as soon as the address is printed
            m = re.search(r"serving (http://127\.0\.0\.1:\d+)/", open(self.out).read())
            if m:
                self.url = m.group(1)
                break
            time.sleep(0.05)
        if not self.url:
            raise SystemExit("tallyd serve did not start")
        self.counted = {}  # (route, code) -> requests this test made

    def call(self, method, path, route, body=None):
        data = json.dumps(body).encode() if body is not None else None
        req = urllib.request.Request(self.url + path, data=data, method=method,
                                     headers={"Content-Type": "application/json"} if data else {})
        try:
            with urllib.request.urlopen(req, timeout=30) as r:
                code, text = r.status, r.read()
        except urllib.error.HTTPError as e:
            code, text = e.code, e.read()
        key = (route, str(code))
        self.counted[key] = self.counted.get(key, 0) + 1
        return code, (json.loads(text) if text and path != "/metrics" else text.decode())

    def scrape(self):
        code, text = self.call("GET", "/metrics", "/metrics")
        assert code == 200, code
        samples = {}
        for family in text_string_to_metric_families(text):
            for s in family.samples:
                samples[(s.name, tuple(sorted(s.labels.items())))] = s.value
        return samples

    def wait(self, job, statuses=("done", "failed", "cancelled")):
        for _ in range(600):
            code, body = self.call("GET", f"/api/captures/{job}", "/api/captures/{id}")
            if body.get("status") in statuses:
                return body
            time.sleep(0.1)
        raise SystemExit(f"job {job} did not finish")

    def stop(self):
        self.proc.send_signal(signal.SIGTERM)
        self.proc.wait(timeout=30)


def value(samples, name, **labels):
    return samples.get((name, tuple(sorted(labels.items()))), 0.0)


TINY = {"renderers": ["forward", "deferred"], "scenes": [{"name": "planes", "layers": 2}],
        "resolutions": [[64, 36]], "cameras": [{"eye": [0, 0, 0], "target": [0, 0, -1]}], "frames": 2, "lights": 4}
LONG = dict(TINY, cameras="auto", resolutions=[[64, 36], [96, 54], [128, 72]], frames=8)

folder = tempfile.mkdtemp(prefix="tally-metrics-")
d = Daemon(folder)
try:
    before = d.scrape()
    check(value(before, "tally_jobs_finished_total", status="done") == 0, "no job done at start")
    check(value(before, "tally_jobs", state="queued") == 0, "queue depth 0 at start")
    check(value(before, "tally_store_bytes", file="db") == os.path.getsize(os.path.join(folder, "tally.db")),
          "store size is the database file's size")
    check(value(before, "tally_queue_limit", limit="queue") == 1000 and
          value(before, "tally_queue_limit", limit="client") == 100, "the queue's limits are the defaults")
    check(all(("tally_captures_limited_total", (("limit", l),)) in before for l in ("queue", "client")),
          "429s by queue limit are counted from 0")
    check(value(before, "tally_store_up") == 1, "the store is healthy at start")
    check(not any(name == "tally_store_fault" for name, _ in before), "no store fault is open at start")
    check(value(before, "tally_store_check_seconds") >= 0, "the start check's time is there")

    code, job = d.call("POST", "/api/captures", "/api/captures", TINY)
    check(code == 202, f"capture accepted ({code})")
    done = d.wait(job["id"])
    check(done["status"] == "done", "the capture is done")
    # The worker stores the job as done, then counts it: wait (bounded) for
    # the counts rather than reading in between
    # (the device's info is the callback's last step).
    for _ in range(100):
        after = d.scrape()
        if any(name == "tally_device_info" and dict(labels).get("device") for name, labels in after):
            break
        time.sleep(0.05)
    check(value(after, "tally_jobs_finished_total", status="done") == 1, "jobs done +1")
    check(value(after, "tally_capture_duration_seconds_count", kind="capture", status="done") == 1,
          "one capture duration observed")
    dur = value(after, "tally_capture_duration_seconds_sum", kind="capture", status="done")
    check(0 < dur < 600, f"its duration is plausible ({dur:.2f} s)")
    check(value(after, "tally_capture_duration_seconds_bucket", kind="capture", status="done", le="+Inf") == 1,
          "the +Inf bucket holds it")
    check(value(after, "tally_jobs", state="done") == 1, "one job done in the store")
    code, runs = d.call("GET", "/api/runs", "/api/runs")
    device = runs["runs"][0]["device"]
    check(value(after, "tally_device_info", selector="auto", device=device) == 1,
          f"device_info names the runs' device ({device})")
    code, health = d.call("GET", "/api/health", "/api/health")
    check(any(k[0] == "tally_build_info" and dict(k[1]).get("commit") == health["commit"] for k in after),
          "build_info names the commit /api/health names")
    check(runs["runs"][0]["tally_commit"] == health["commit"], "the run records the build's commit")

    # Cancelled: one job while it runs, one while it waits behind it.
    code, running = d.call("POST", "/api/captures", "/api/captures", LONG)
    code, waiting = d.call("POST", "/api/captures", "/api/captures", LONG)
    d.wait(running["id"], ("running", "done", "failed"))
    code, _ = d.call("DELETE", f"/api/captures/{waiting['id']}", "/api/captures/{id}")
    check(code == 200, "the waiting job is cancelled")
    code, _ = d.call("DELETE", f"/api/captures/{running['id']}", "/api/captures/{id}")
    check(code == 200, "the running job is cancelled")
    for _ in range(600):  # the worker reports the running one when its child has stopped (a minute at most)
        if value(d.scrape(), "tally_jobs_finished_total", status="cancelled") >= 2:
            break
        time.sleep(0.1)
    final = d.scrape()
    check(value(final, "tally_jobs_finished_total", status="cancelled") == 2, "jobs cancelled +2")
    check(value(final, "tally_jobs", state="cancelled") == 2, "two cancelled jobs in the store")
    check(value(final, "tally_jobs", state="queued") == 0 and value(final, "tally_jobs", state="running") == 0,
          "the queue is empty again")

    # Every request of this test, counted under its route and code. A request
    # is counted once its response is written, so a scrape sent as soon as the
    # previous response arrived may come before that one is counted (it is
    # handled on another thread): scrape again, a bounded number of times,
    # until every earlier scrape is in. The last scrape is never in its own
    # answer.
    for _ in range(600):  # bounded (30 s), ended by the count, not by a time
        made = d.counted[("/metrics", "200")]
        if value(final, "tally_http_requests_total", route="/metrics", code="200") >= made - 1:
            break
        time.sleep(0.05)
        final = d.scrape()
    d.counted[("/metrics", "200")] -= 1
    for (route, code), n in sorted(d.counted.items()):
        got = value(final, "tally_http_requests_total", route=route, code=code)
        check(got == n, f"{route} {code}: {n} requests made, {got:g} counted")
    check(value(final, "tally_http_request_duration_seconds_count", route="/api/captures") == 3,
          "three POST /api/captures timed")
finally:
    d.stop()

log = open(os.path.join(folder, "serve.err")).read()
first = job["id"]
check(re.search(rf"^ts=\S+ level=info job={first} msg=running$", log, re.M) is not None, "log: the job running")
check(re.search(rf'^ts=\S+ level=info job={first} msg="done, 2 runs"$', log, re.M) is not None, "log: the job done")
check(re.search(rf"^ts=\S+ level=info job={running['id']} msg=cancelled$", log, re.M) is not None,
      "log: the running job cancelled")
check(all(re.match(r"^ts=\S+ level=(debug|info|warning|error)( job=\d+)? msg=", l) for l in log.splitlines() if l),
      "every log line has a time, a level and a message")
if failures:
    print(log)
else:
    shutil.rmtree(folder)
print(f"{len(failures)} failed")
sys.exit(1 if failures else 0)
