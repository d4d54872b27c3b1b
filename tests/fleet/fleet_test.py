#!/usr/bin/env python3
"""A fleet on one machine, on lavapipe: one PostgreSQL (started here with
initdb and pg_ctl), one API daemon and three workers sharing it. Two workers
pretend to be other GPUs (--device-name-override). 30 small captures are
submitted, some naming a device; one more names a device nobody has and must
wait, saying why. One worker is killed with SIGKILL mid-capture.

Checked afterwards:
  - every job ended done, the killed worker's too;
  - the killed worker's job was queued again and finished elsewhere, its
    attempt errors naming the lost lease;
  - jobs naming a device ran only on the worker that has it;
  - no job ran on two hosts at once (the workers' log lines: each attempt's
    interval, from "running" to its end or the kill, never overlaps another
    attempt of the same job);
  - each run is stored once (one run per job, stamped with the host that
    finished it), and the API lists all of them with their hosts;
  - GET /api/hosts lists the three workers, the killed one no longer alive,
    and jobs done per host add up;
  - a queued job nobody can run says why, and cancelling it works;
  - with the database stopped mid-capture, the worker keeps its capture and
    retries the ingest until it is back; the API answers 503 meanwhile; the
    result is stored once;
  - with node and Chromium present, the dashboard's hosts view and runs
    browser show the hosts (tests/web/fleet_check.mjs).

  fleet_test.py --tallyd PATH --web WEB_ROOT
"""
import argparse
import json
import os
import re
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
import urllib.error
import urllib.request

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "support"))
from pgserver import PostgresServer  # noqa: E402
from strict import strict  # noqa: E402

JOBS = 30
LEASE_S = 3
STALE_S = 4


def fail(message):
    print("FAIL: " + message, flush=True)
    sys.exit(1)


def check(condition, message):
    if not condition:
        fail(message)


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class Api:
    def __init__(self, port):
        self.base = "http://127.0.0.1:%d" % port

    def call(self, method, path, body=None):
        data = json.dumps(body).encode() if body is not None else None
        request = urllib.request.Request(self.base + path, data=data, method=method,
                                         headers={"Content-Type": "application/json"} if data else {})
        try:
            with urllib.request.urlopen(request, timeout=30) as r:
                return r.status, json.loads(r.read() or b"null")
        except urllib.error.HTTPError as e:
            return e.code, json.loads(e.read() or b"null")

    def get(self, path):
        status, body = self.call("GET", path)
        check(status == 200, "GET %s: %d %s" % (path, status, body))
        return body

    def all_captures(self):
        out, cursor = [], None
        while True:
            page = self.get("/api/captures?limit=100" + ("&cursor=" + cursor if cursor else ""))
            out += page["captures"]
            cursor = page["next_cursor"]
            if not cursor:
                return out


def spec(i):
    # A tiny capture (a few seconds on lavapipe), each one different.
    return {"renderers": ["forward"], "scenes": ["planes"], "resolutions": [[64 + 8 * (i % 4), 64]], "frames": 2}


def parse_log(path):
    """(job, event, time) from a worker's log lines: running, done, failed, stopped."""
    events = []
    pattern = re.compile(r"ts=(\S+) level=\w+ job=(\d+) msg=(\"[^\"]*\"|\S+)")
    with open(path, errors="replace") as f:
        for line in f:
            m = pattern.search(line)
            if not m:
                continue
            stamp = time.mktime(time.strptime(m.group(1)[:19], "%Y-%m-%dT%H:%M:%S")) + float("0." + m.group(1)[20:23])
            events.append((int(m.group(2)), m.group(3).strip('"'), stamp))
    return events


def attempt_intervals(name, events, killed_at):
    """Per job, the intervals this worker worked on it: from "running" to the next line ending it."""
    intervals = []
    open_jobs = {}
    for job, message, stamp in events:
        if message == "running":
            open_jobs[job] = stamp
        elif job in open_jobs and (message.startswith("done") or message.startswith("failed") or
                                   message.startswith("stopped") or message == "cancelled"):
            intervals.append((job, open_jobs.pop(job), stamp, name))
    for job, start in open_jobs.items():
        intervals.append((job, start, killed_at if killed_at else time.time(), name))
    return intervals


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--tallyd", required=True)
    parser.add_argument("--web", required=True)
    parser.add_argument("--keep", action="store_true", help="keep the folder with the logs")
    args = parser.parse_args()

    work = tempfile.mkdtemp(prefix="tally-fleet-")
    processes = {}
    logs = {}
    server = PostgresServer()
    try:
        server.start()
        url = server.create_database("fleet")
        env = dict(os.environ, TMPDIR=work)

        def start(name, extra):
            logs[name] = os.path.join(work, name + ".log")
            processes[name] = subprocess.Popen(
                [args.tallyd, "serve", "--store", url, "--lease", str(LEASE_S), "--stale-after", str(STALE_S),
                 "--max-attempts", "3"] + extra,
                stdout=open(os.path.join(work, name + ".out"), "w"), stderr=open(logs[name], "w"), env=env)

        port = free_port()
        start("api", ["--role", "api", "--port", str(port), "--web", args.web])
        start("worker-a", ["--role", "worker", "--host-name", "worker-a"])
        start("worker-b", ["--role", "worker", "--host-name", "worker-b", "--device-name-override", "FakeGPU-B"])
        start("worker-c", ["--role", "worker", "--host-name", "worker-c", "--device-name-override", "FakeGPU-C"])
        api = Api(port)
        end = time.time() + 60
        while True:
            try:
                hosts = api.get("/api/hosts")["hosts"]
                if len([h for h in hosts if h["alive"]]) == 3:
                    break
            except (urllib.error.URLError, ConnectionError, OSError):
                pass
            for name, p in processes.items():
                check(p.poll() is None, "%s exited at start: %s" % (name, open(logs[name]).read()[-2000:]))
            check(time.time() < end, "the three workers did not register within 60 s")
            time.sleep(0.2)
        by_name = {h["name"]: h for h in hosts}
        check(by_name["worker-b"]["device"]["name"] == "FakeGPU-B", "worker-b reports %s" % by_name["worker-b"])
        check(by_name["worker-b"]["device_override"] == "FakeGPU-B", "worker-b's override is not shown")
        check(by_name["worker-a"]["device"] is not None, "worker-a probed no device")

        # 30 jobs: every fifth for FakeGPU-B, every seventh (not fifth) for FakeGPU-C.
        wanted = {}
        for i in range(JOBS):
            body = spec(i)
            if i % 5 == 0:
                body["device"] = "FakeGPU-B"
            elif i % 7 == 0:
                body["device"] = {"name": "fakegpu-c"}  # case-insensitive substring
            status, reply = api.call("POST", "/api/captures", body)
            check(status == 202, "POST capture %d: %d %s" % (i, status, reply))
            wanted[reply["id"]] = body.get("device")
        status, reply = api.call("POST", "/api/captures", dict(spec(0), device={"vendor": "NoSuchVendor"}))
        check(status == 202, "POST an unrunnable capture: %d %s" % (status, reply))
        orphan = reply["id"]
        status, reply = api.call("POST", "/api/captures", dict(spec(0), device={"features": "x"}))
        check(status == 400 and "device.features" in json.dumps(reply), "a bad device requirement: %d %s" % (status, reply))

        # Kill worker-a with SIGKILL while it holds a job.
        killed_job, killed_at = None, None
        end = time.time() + 120
        while killed_job is None:
            check(time.time() < end, "worker-a never took a job")
            for job in api.all_captures():
                if job["status"] == "running" and job["host"] == "worker-a" and job["progress"]["total"] > 0:
                    killed_job = job["id"]
            if killed_job is None:
                time.sleep(0.1)
        processes["worker-a"].send_signal(signal.SIGKILL)
        processes["worker-a"].wait()
        killed_at = time.time()
        print("killed worker-a holding job %d" % killed_job, flush=True)

        # The job nobody can run says why.
        j = api.get("/api/captures/%d" % orphan)
        check(j["status"] == "queued", "the unrunnable job is %s" % j["status"])
        check(j["waiting"] and "no live worker has a device matching" in j["waiting"] and "NoSuchVendor" in j["waiting"],
              "waiting reason: %r" % j["waiting"])

        # Everything else ends.
        end = time.time() + 600
        while True:
            jobs = {j["id"]: j for j in api.all_captures() if j["id"] in wanted}
            if all(j["status"] in ("done", "failed", "cancelled") for j in jobs.values()):
                break
            check(time.time() < end, "jobs still open after 600 s: %s" %
                  [(j["id"], j["status"], j["host"]) for j in jobs.values() if j["status"] not in ("done", "failed")])
            time.sleep(0.5)
        status, reply = api.call("DELETE", "/api/captures/%d" % orphan)
        check(status == 200 and reply["status"] == "cancelled", "cancel the unrunnable job: %d %s" % (status, reply))

        # Every job is done: the killed worker's job too, on its next attempt
        # (max_attempts leaves room for it), and none is let off as failed.
        failed = [j for j in jobs.values() if j["status"] != "done"]
        check(not failed, "%d of %d jobs not done: %s" %
              (len(failed), JOBS, [(j["id"], j["status"], j["error"], j["attempt_errors"]) for j in failed]))
        done = [j for j in jobs.values() if j["status"] == "done"]
        check(len(done) == JOBS, "%d of %d jobs done" % (len(done), JOBS))
        k = jobs[killed_job]
        check(k["attempts"] >= 2, "the killed worker's job was not claimed again: %s" % k)
        check(any("worker-a" in e and "lease expired" in e for e in k["attempt_errors"]),
              "the killed worker's job does not say why attempt 1 ended: %s" % k["attempt_errors"])
        check(k["host"] != "worker-a", "the killed worker's job is still on worker-a")

        # Jobs naming a device ran where that device is.
        home = {"FakeGPU-B": "worker-b"}
        for job_id, device in wanted.items():
            j = jobs[job_id]
            if device == "FakeGPU-B":
                check(j["host"] == "worker-b", "job %d for FakeGPU-B ran on %s" % (job_id, j["host"]))
            elif device is not None:
                check(j["host"] == "worker-c", "job %d for FakeGPU-C ran on %s" % (job_id, j["host"]))

        # Each run stored once, with its host; the API lists all of them.
        runs = []
        cursor = None
        while True:
            page = api.get("/api/runs?limit=1000" + ("&cursor=" + cursor if cursor else ""))
            runs += page["runs"]
            cursor = page["next_cursor"]
            if not cursor:
                break
        per_job = {}
        for r in runs:
            per_job.setdefault(r["capture"], []).append(r)
        for j in done:
            stored = per_job.get(j["id"], [])
            check(len(stored) == 1, "job %d has %d runs stored" % (j["id"], len(stored)))
            check(stored[0]["host"] == j["host"], "job %d's run says host %s, the job %s" %
                  (j["id"], stored[0]["host"], j["host"]))
            if j["host"] in ("worker-b", "worker-c"):
                check(stored[0]["device"] == {"worker-b": "FakeGPU-B", "worker-c": "FakeGPU-C"}[j["host"]],
                      "job %d's run records device %s" % (j["id"], stored[0]["device"]))
        for host in ("worker-b", "worker-c"):
            filtered = api.get("/api/runs?limit=1000&host=" + host)["runs"]
            check(sorted(r["id"] for r in filtered) == sorted(r["id"] for r in runs if r["host"] == host),
                  "GET /api/runs?host=%s differs from the runs with that host" % host)

        # No job ran on two hosts at once.
        intervals = []
        for name in ("worker-a", "worker-b", "worker-c"):
            intervals += attempt_intervals(name, parse_log(logs[name]), killed_at if name == "worker-a" else None)
        by_job = {}
        for job, start_t, end_t, name in intervals:
            by_job.setdefault(job, []).append((start_t, end_t, name))
        for job, spans in by_job.items():
            spans.sort()
            for (s1, e1, n1), (s2, e2, n2) in zip(spans, spans[1:]):
                check(s2 >= e1, "job %d ran on %s (%.3f-%.3f) and %s (%.3f-%.3f) at once" % (job, n1, s1, e1, n2, s2, e2))
        ran_twice = [job for job, spans in by_job.items() if len(spans) > 1]
        check(killed_job in ran_twice, "the killed job's two attempts are not both in the logs: %s" % by_job.get(killed_job))

        # Hosts: the killed one stale, the counts add up.
        time.sleep(STALE_S + 1)
        hosts = {h["name"]: h for h in api.get("/api/hosts")["hosts"]}
        check(set(hosts) == {"worker-a", "worker-b", "worker-c"}, "hosts: %s" % sorted(hosts))
        check(not hosts["worker-a"]["alive"], "worker-a is still alive after SIGKILL")
        check(hosts["worker-b"]["alive"] and hosts["worker-c"]["alive"], "a surviving worker is not alive")
        for name, h in hosts.items():
            ran_here = len([j for j in done if j["host"] == name])
            check(h["jobs_done"] == ran_here, "%s counts %d jobs done, the jobs say %d" % (name, h["jobs_done"], ran_here))
        print("jobs done per host: " + ", ".join("%s %d" % (n, hosts[n]["jobs_done"]) for n in sorted(hosts)), flush=True)

        # The dashboard, where a browser is available.
        check_script = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "web", "fleet_check.mjs")
        web_tests = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "web")
        if shutil.which("node") and os.path.isdir(os.path.join(web_tests, "node_modules", "playwright-core")) \
                and os.path.exists(check_script):
            result = subprocess.run(["node", check_script, api.base, "worker-a,worker-b,worker-c"],
                                    capture_output=True, text=True, timeout=180, cwd=web_tests)
            check(result.returncode == 0, "dashboard check: %s%s" % (result.stdout[-2000:], result.stderr[-2000:]))
            print(result.stdout.strip(), flush=True)
        elif strict():
            fail("node, playwright-core or the dashboard check is missing")

        # The database goes away mid-capture: the worker keeps its capture,
        # retries the ingest until the database is back, and the result is
        # stored once (by it, or, had its lease been taken meanwhile, by the
        # worker that ran the job again). The API answers 503
        # store_unavailable meanwhile (with Retry-After; health says the store
        # is unreachable) and reconnects afterwards.
        status, reply = api.call("POST", "/api/captures", dict(spec(1), frames=4))
        check(status == 202, "POST the outage capture: %d %s" % (status, reply))
        outage = reply["id"]
        end = time.time() + 180
        holder = None
        while holder is None:
            check(time.time() < end, "the outage capture never ran")
            j = api.get("/api/captures/%d" % outage)
            if j["status"] == "running" and j["progress"]["done"] > 0:
                holder = j["host"]
            else:
                check(j["status"] in ("queued", "running"), "the outage capture ended first: %s" % j)
                time.sleep(0.05)
        server.pause()
        status, reply = api.call("GET", "/api/captures/%d" % outage)
        check(status == 503 and reply["error"]["code"] == "store_unavailable" and
              "cannot be reached" in reply["error"]["message"], "GET with the database down: %d %s" % (status, reply))
        status, reply = api.call("GET", "/api/health")
        check(status == 503 and reply["store"]["status"] == "unreachable", "health with the database down: %d %s" % (status, reply))
        end = time.time() + 240
        while "cannot reach the database to store the result" not in open(logs[holder], errors="replace").read():
            check(time.time() < end, "%s never retried its ingest: %s" % (holder, open(logs[holder]).read()[-1500:]))
            check(processes[holder].poll() is None, "%s exited while the database was down" % holder)
            time.sleep(0.2)
        server.resume()
        end = time.time() + 120
        while True:
            status, j = api.call("GET", "/api/captures/%d" % outage)
            if status == 200 and j["status"] in ("done", "failed"):
                break
            check(time.time() < end, "the outage capture did not end after the database came back: %d %s" % (status, j))
            time.sleep(0.3)
        check(j["status"] == "done", "the outage capture ended %s: %s" % (j["status"], j))
        # Each HTTP thread has its own reader: one whose connection died in the
        # outage answers 503 once, then reconnects (bounded wait for that).
        end = time.time() + 30
        while True:
            status, reply = api.call("GET", "/api/runs?capture=%d" % outage)
            if status != 503 or time.time() > end:
                break
            time.sleep(0.3)
        check(status == 200, "GET /api/runs after the database came back: %d %s" % (status, reply))
        stored = reply["runs"]
        check(len(stored) == 1 and stored[0]["host"] == j["host"],
              "the outage capture stored %d runs: %s" % (len(stored), stored))
        print("database outage: %s kept capture %d and retried its ingest; stored once, by %s (attempt %d)" %
              (holder, outage, j["host"], j["attempts"]), flush=True)

        for name in ("worker-b", "worker-c", "api"):
            processes[name].send_signal(signal.SIGTERM)
        for name in ("worker-b", "worker-c", "api"):
            code = processes[name].wait(timeout=60)
            check(code == 0, "%s exited %d on SIGTERM" % (name, code))
        print("PASS: %d jobs over 3 workers, %d done, %d failed; job %d survived its worker's SIGKILL" %
              (JOBS, len(done), len(failed), killed_job), flush=True)
    finally:
        for p in processes.values():
            if p.poll() is None:
                p.kill()
                p.wait()
        server.stop()
        if args.keep:
            print("logs in " + work)
        else:
            shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
