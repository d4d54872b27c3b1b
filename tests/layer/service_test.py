#!/usr/bin/env python3
"""Applications through the daemon with the real layer, on lavapipe:
`tallyd serve --allow-applications` (posting with its application token; a
copy of vkcube and the compute application in its --application-root; as
nobody when the test runs as root), then capture jobs of vkcube under Xvfb
(stored and served like any run, named as the application names it), of the
compute application crashing, hanging past its deadline and using every
descriptor set in every layout (each job fails with its reason), and vkcube
again afterwards: the daemon kept running and stored nothing half-written.

  service_test.py --tallyd PATH --build BUILD_DIR
"""
import argparse
import json
import os
import shutil
import socket
import subprocess
import sys
import tempfile
import time
import urllib.request


def fail(message):
    print("FAIL: " + message)
    sys.exit(1)


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class Api:
    def __init__(self, port, token):
        self.base = "http://127.0.0.1:%d" % port
        self.auth = {"Authorization": "Bearer " + token}

    def get(self, path):
        with urllib.request.urlopen(urllib.request.Request(self.base + path, headers=self.auth), timeout=30) as r:
            return json.loads(r.read())

    def post(self, path, body):
        request = urllib.request.Request(self.base + path, data=json.dumps(body).encode(),
                                         headers=dict(self.auth, **{"Content-Type": "application/json"}),
                                         method="POST")
        with urllib.request.urlopen(request, timeout=30) as r:
            return json.loads(r.read())

    def wait(self, job, timeout=240):
        end = time.time() + timeout
        while time.time() < end:
            j = self.get("/api/captures/%d" % job)
            if j["status"] in ("done", "failed", "cancelled"):
                return j
            time.sleep(0.3)
        fail("job %d did not finish within %d s" % (job, timeout))


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--tallyd", required=True)
    parser.add_argument("--build", required=True)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="tally-layer-service-") as tmp:
        # The applications' root: copies of vkcube and the compute application
        # (nobody, whom they run as under root, must reach them).
        os.chmod(tmp, 0o755)
        apps = os.path.join(tmp, "apps")
        os.mkdir(apps)
        vkcube_path = shutil.copy2(shutil.which("vkcube") or fail("vkcube is not installed"), apps)
        app = shutil.copy2(os.path.join(os.path.abspath(args.build), "tests", "layer", "tally_layer_compute_app"), apps)
        tokens = os.path.join(tmp, "tokens")
        token = "app1ication-0123456789abcdefghijklmnop"
        with open(os.open(tokens, os.O_WRONLY | os.O_CREAT, 0o600), "w") as f:
            f.write("read=r3ad-0123456789abcdefghijklmnopqrstuv\ncapture=c4pture-0123456789abcdefghijklmnopqrst\n"
                    "application=%s\n" % token)
        port = free_port()
        env = dict(os.environ, TALLY_LAYER_PATH=os.path.join(os.path.abspath(args.build), "layer"))
        log = open(os.path.join(tmp, "tallyd.log"), "w")
        flags = ["--allow-applications", "--token-file", tokens, "--application-root", apps]
        if os.geteuid() == 0:
            flags += ["--run-as", "nobody"]
        daemon = subprocess.Popen([args.tallyd, "serve", "--db", os.path.join(tmp, "tally.db"), "--port", str(port)]
                                  + flags, env=env, stdout=log, stderr=subprocess.STDOUT)
        try:
            api = Api(port, token)
            for _ in range(100):
                try:
                    api.get("/api/health")
                    break
                except OSError:
                    time.sleep(0.1)
            vkcube = {"application": {"command": [vkcube_path, "--c", "20"], "frames": 3, "skip_frames": 2,
                                      "display": "xvfb"}}
            jobs = {
                "vkcube": api.post("/api/captures", vkcube)["id"],
                "crash": api.post("/api/captures", {"application": {
                    "command": [app, "--frames", "6", "--crash-after", "2"], "frames": 4, "frame_submits": 1}})["id"],
                "hang": api.post("/api/captures", {"application": {
                    "command": [app, "--frames", "6", "--hang-after", "1"], "frames": 3, "frame_submits": 1,
                    "timeout_s": 4}})["id"],
                "all-sets": api.post("/api/captures", {"application": {
                    "command": [app, "--frames", "4", "--all-sets-only", "1"], "frames": 2, "frame_submits": 1}})["id"],
                "again": api.post("/api/captures", vkcube)["id"],
            }
            done = {name: api.wait(job) for name, job in jobs.items()}
            expect_error = {"crash": "signal 11 (SIGSEGV)", "hang": "did not deliver 3 frames",
                            "all-sets": "uses every descriptor set"}
            for name, text in expect_error.items():
                j = done[name]
                if j["status"] != "failed" or text not in (j.get("error") or ""):
                    fail("%s: status %s, error %r; expected a failure naming %r" % (name, j["status"], j.get("error"), text))
            for name in ("vkcube", "again"):
                if done[name]["status"] != "done":
                    fail("%s: %s %s" % (name, done[name]["status"], done[name].get("error")))
            runs = api.get("/api/runs?capture=%d" % jobs["again"])["runs"]
            if len(runs) != 1 or runs[0]["renderer"] != "app:vkcube" or runs[0]["sample_count"] != 3:
                fail("the vkcube job stored %s" % runs)
            run = api.get("/api/runs/%d" % runs[0]["id"])
            passes = run["passes"]
            if len(passes) != 1:
                fail("vkcube's run has passes %s" % [p["name"] for p in passes])
            names = {r["name"] for r in passes[0]["resources"]}
            if "swapchain" not in names or not any(n.startswith("texture 0x") for n in names):
                fail("vkcube's resources are named %s" % sorted(names))
            # Nothing of the failed jobs was stored.
            all_runs = api.get("/api/runs?limit=100")["runs"]
            if sorted(r["capture"] for r in all_runs) != sorted([jobs["vkcube"], jobs["again"]]):
                fail("stored runs of captures %s, expected only the two vkcube jobs" %
                     sorted(r["capture"] for r in all_runs))
            if daemon.poll() is not None:
                fail("the daemon exited")
            print("service: vkcube stored twice as app:vkcube (3 frames each); crash, hang and every-set jobs "
                  "failed with their reasons; nothing else stored")
        finally:
            daemon.terminate()
            daemon.wait(timeout=30)


if __name__ == "__main__":
    main()
