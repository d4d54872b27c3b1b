// A `tallyd serve` child for the browser tests: 127.0.0.1, an ephemeral port,
// a temp database, the dashboard from web/. Captures go through the REST API
// exactly as the dashboard's would, and run on whatever Vulkan device the
// machine has (lavapipe without a GPU).
import { spawn } from 'node:child_process';
import { mkdirSync, mkdtempSync, rmSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { join } from 'node:path';
import { setTimeout as sleep } from 'node:timers/promises';

const kStartMs = 30_000;  // the daemon prints its address within this
const kStopMs = 10_000;   // SIGTERM, then SIGKILL

export class Daemon {
  // options.args: more `tallyd serve` flags; options.env: more environment;
  // options.token: the bearer token api() sends (none by default).
  constructor(tallyd, webRoot, options = {}) {
    this.tallyd = tallyd;
    this.webRoot = webRoot;
    this.args = options.args || [];
    this.env = options.env || {};
    this.token = options.token || '';
    this.dir = mkdtempSync(join(tmpdir(), 'tally-web-'));
    // glTF scenes the tests write (--scenes: the daemon reads glTF files only from here).
    this.scenes = join(this.dir, 'scenes');
    mkdirSync(this.scenes);
    this.log = '';
  }

  async start() {
    // Captures' temp files (specs, results) live in our folder too.
    this.child = spawn(this.tallyd, ['serve', '--db', join(this.dir, 'tally.db'), '--port', '0', '--web', this.webRoot, '--scenes', this.scenes, ...this.args],
      { stdio: ['ignore', 'pipe', 'pipe'], env: { ...process.env, TMPDIR: this.dir, ...this.env } });
    this.child.stderr.on('data', (d) => { this.log += d; });
    const exited = new Promise((resolve) => this.child.once('exit', (code, signal) => resolve({ code, signal })));
    const address = new Promise((resolve) => {
      let out = '';
      this.child.stdout.on('data', (d) => {
        out += d;
        const m = /tallyd: serving (http:\/\/127\.0\.0\.1:\d+)\//.exec(out);
        if (m) resolve(m[1]);
      });
    });
    const found = await Promise.race([
      address,
      exited.then((e) => { throw new Error(`tallyd serve exited (${JSON.stringify(e)}): ${this.log}`); }),
      sleep(kStartMs, undefined, { ref: false }).then(() => { throw new Error(`tallyd serve printed no address in ${kStartMs} ms: ${this.log}`); }),
    ]);
    this.url = found;
    this.exited = exited;
    return this;
  }

  async stop() {
    if (this.child && this.child.exitCode === null && this.child.signalCode === null) {
      this.child.kill('SIGTERM');
      const stopped = await Promise.race([this.exited.then(() => true), sleep(kStopMs).then(() => false)]);
      if (!stopped) this.child.kill('SIGKILL');
      await this.exited;
    }
    rmSync(this.dir, { recursive: true, force: true });
  }

  // JSON from the API: {status, body}.
  async api(path, { method = 'GET', body } = {}) {
    const init = { method, headers: {} };
    if (this.token) init.headers.Authorization = `Bearer ${this.token}`;
    if (body !== undefined) {
      init.headers['Content-Type'] = 'application/json';
      init.body = JSON.stringify(body);
    }
    const response = await fetch(this.url + '/api' + path, init);
    return { status: response.status, body: await response.json() };
  }

  async get(path) {
    const { status, body } = await this.api(path);
    if (status !== 200) throw new Error(`GET ${path}: ${status} ${JSON.stringify(body)}`);
    return body;
  }

  // Posts a capture spec and waits (polling, bounded by deadlineMs) until the
  // job has finished; throws unless it is done.
  async capture(spec, deadlineMs = 240_000) {
    const { status, body } = await this.api('/captures', { method: 'POST', body: spec });
    if (status !== 202) throw new Error(`POST /captures: ${status} ${JSON.stringify(body)}`);
    return this.waitFor(body.id, deadlineMs);
  }

  async waitFor(id, deadlineMs = 240_000) {
    const until = Date.now() + deadlineMs;
    while (Date.now() < until) {
      const job = await this.get(`/captures/${id}`);
      if (job.status === 'done') return job;
      if (job.status === 'failed' || job.status === 'cancelled') throw new Error(`capture ${id} ${job.status}: ${job.error}\n${this.log}`);
      await sleep(250);
    }
    throw new Error(`capture ${id} did not finish in ${deadlineMs} ms`);
  }
}
