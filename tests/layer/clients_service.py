"""glmark2 through zink and ffmpeg's avgblur_vulkan captured by the daemon
(`tallyd serve --allow-applications`, POST /api/captures with the
application token; copies of both programs in its --application-root; as
nobody when the test runs as root): each job is done, its run stored under
the application's name with one sample per frame, and the stored frames,
read back through the API, hold the relations the direct captures hold
(clients_relations.py)."""
import os
import shutil
import subprocess
import time

import clients_relations as relations
from service_test import Api, free_port

W, H = 320, 240


def stored_run(api, job, failures, name, frames):
    """The run the job stored, as the API serves it, in the shape
    clients_relations reads (a capture result's run): its frames are the
    samples of /api/samples/{id}; None where it is not one run of `frames`."""
    runs = api.get("/api/runs?capture=%d" % job)["runs"]
    if not failures.check(len(runs) == 1 and runs[0]["renderer"] == "app:" + name
                          and runs[0]["sample_count"] == frames,
                          "%s: stored %s, expected one app:%s run of %d frames" %
                          (name, [(r["renderer"], r["sample_count"]) for r in runs], name, frames)):
        return None
    run = api.get("/api/runs/%d" % runs[0]["id"])
    samples = api.get("/api/runs/%d/samples" % runs[0]["id"])["samples"]
    return {"renderer": run["renderer"], "width": run["width"], "height": run["height"], "notes": run["notes"],
            "resources": {"list": run["resources"]},
            "samples": [api.get("/api/samples/%d" % s["id"]) for s in samples]}


def start_daemon(args, tmp, apps):
    tokens = os.path.join(tmp, "tokens")
    token = "app1ication-0123456789abcdefghijklmnop"
    with open(os.open(tokens, os.O_WRONLY | os.O_CREAT, 0o600), "w") as f:
        f.write("read=r3ad-0123456789abcdefghijklmnopqrstuv\ncapture=c4pture-0123456789abcdefghijklmnopqrst\n"
                "application=%s\n" % token)
    port = free_port()
    env = dict(os.environ, TALLY_LAYER_PATH=args.layer_dir)
    flags = ["--allow-applications", "--token-file", tokens, "--application-root", apps]
    if os.geteuid() == 0:
        flags += ["--run-as", "nobody"]
    log = open(os.path.join(tmp, "tallyd.log"), "w")
    daemon = subprocess.Popen([args.tallyd, "serve", "--db", os.path.join(tmp, "tally.db"), "--port", str(port)]
                              + flags, env=env, stdout=log, stderr=subprocess.STDOUT)
    return daemon, Api(port, token)


def run(args, tmp, glmark2_spec, ffmpeg_spec, failures):
    os.chmod(tmp, 0o755)
    apps = os.path.join(tmp, "apps")
    os.mkdir(apps)
    glmark2_spec["application"]["command"][0] = shutil.copy2(shutil.which("glmark2"), apps)
    ffmpeg_spec["application"]["command"][0] = shutil.copy2(shutil.which("ffmpeg"), apps)
    daemon, api = start_daemon(args, tmp, apps)
    try:
        for _ in range(100):
            try:
                api.get("/api/health")
                break
            except OSError:
                time.sleep(0.1)
        jobs = {"glmark2": api.post("/api/captures", glmark2_spec)["id"],
                "ffmpeg": api.post("/api/captures", ffmpeg_spec)["id"]}
        for name, job in jobs.items():
            failures.prefix = name + ": "
            j = api.wait(job)
            if not failures.check(j["status"] == "done", "%s: job %s: %s" % (name, j["status"], j.get("error"))):
                continue
            spec = (glmark2_spec if name == "glmark2" else ffmpeg_spec)["application"]
            stored = stored_run(api, job, failures, name, spec["frames"])
            if stored is None:
                continue
            if name == "glmark2":
                relations.glmark2_common(stored, failures, W, H, spec["skip_frames"], spec["frames"])
                relations.glmark2_texture(stored, failures, W, H)
            else:
                relations.ffmpeg_common(stored, failures, spec["skip_frames"], spec["frames"])
                relations.ffmpeg_avgblur(stored, failures, W, H)
        failures.prefix = ""
        failures.check(daemon.poll() is None, "the daemon exited")
    finally:
        daemon.terminate()
        daemon.wait(timeout=30)
    failures.finish("glmark2 (texture) and ffmpeg (avgblur) stored and served; their stored frames hold the relations")
