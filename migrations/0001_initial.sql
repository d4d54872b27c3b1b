-- Tally's first schema: devices, scenes, capture jobs and their results.
-- Applied in one transaction by server/store/migrations.cpp, which then sets
-- PRAGMA user_version = 1. Never edit a released migration: add 0002_*.sql.
--
-- Conventions: timestamps are UTC ISO-8601 text with milliseconds
-- ("2026-11-21T06:30:00.123Z"); JSON columns hold compact JSON checked with
-- json_valid; counts and bytes are per frame, averaged over a sample's frames
-- (docs/result-schema.md), hence REAL.

-- A Vulkan device as a capture described it. fingerprint joins the fields that
-- identify a device and driver (name, vendor, device id, driver, API version).
CREATE TABLE devices (
  id          INTEGER PRIMARY KEY,
  fingerprint TEXT NOT NULL UNIQUE,
  name        TEXT NOT NULL,
  vendor      TEXT NOT NULL,
  driver      TEXT NOT NULL,
  api_version TEXT NOT NULL,
  features    TEXT NOT NULL DEFAULT '{}' CHECK (json_valid(features)),
  info        TEXT NOT NULL DEFAULT '{}' CHECK (json_valid(info)),   -- the whole "device" object
  created_at  TEXT NOT NULL DEFAULT (strftime('%Y-%m-%dT%H:%M:%fZ', 'now'))
);

-- A scene by name and parameters (params as compact JSON with sorted keys).
CREATE TABLE scenes (
  id     INTEGER PRIMARY KEY,
  name   TEXT NOT NULL,
  params TEXT NOT NULL DEFAULT '{}' CHECK (json_valid(params)),
  UNIQUE (name, params)
);

CREATE TABLE jobs (
  id               INTEGER PRIMARY KEY,
  status           TEXT NOT NULL DEFAULT 'queued'
                   CHECK (status IN ('queued', 'running', 'done', 'failed', 'cancelled')),
  spec             TEXT NOT NULL CHECK (json_valid(spec)),
  progress_done    INTEGER NOT NULL DEFAULT 0 CHECK (progress_done >= 0),
  progress_total   INTEGER NOT NULL DEFAULT 0 CHECK (progress_total >= 0),
  progress_current TEXT,
  error            TEXT,
  attempts         INTEGER NOT NULL DEFAULT 0 CHECK (attempts >= 0),
  idempotency_key  TEXT UNIQUE,
  created_at       TEXT NOT NULL DEFAULT (strftime('%Y-%m-%dT%H:%M:%fZ', 'now')),
  started_at       TEXT,
  finished_at      TEXT,
  worker_pid       INTEGER
);
CREATE INDEX jobs_by_status ON jobs (status, id);

-- One renderer x scene x resolution of a capture job.
CREATE TABLE runs (
  id                  INTEGER PRIMARY KEY,
  job_id              INTEGER NOT NULL REFERENCES jobs (id) ON DELETE CASCADE,
  device_id           INTEGER NOT NULL REFERENCES devices (id),
  renderer            TEXT NOT NULL,
  scene_id            INTEGER NOT NULL REFERENCES scenes (id),
  width               INTEGER NOT NULL CHECK (width BETWEEN 1 AND 16384),
  height              INTEGER NOT NULL CHECK (height BETWEEN 1 AND 16384),
  counting            TEXT NOT NULL,
  lights              INTEGER NOT NULL CHECK (lights >= 0),
  render_target_bytes INTEGER,
  notes               TEXT NOT NULL DEFAULT '{}' CHECK (json_valid(notes)),
  shaders             TEXT NOT NULL DEFAULT '{}' CHECK (json_valid(shaders)),  -- source hashes of the capture
  created_at          TEXT NOT NULL DEFAULT (strftime('%Y-%m-%dT%H:%M:%fZ', 'now'))
);
-- Filters end in id so that "WHERE <filter> AND id < cursor ORDER BY id DESC" walks one index.
CREATE INDEX runs_by_renderer ON runs (renderer, id);
CREATE INDEX runs_by_scene    ON runs (scene_id, id);
CREATE INDEX runs_by_size     ON runs (width, height, id);
CREATE INDEX runs_by_device   ON runs (device_id, id);
CREATE INDEX runs_by_job      ON runs (job_id, id);
CREATE INDEX runs_by_created  ON runs (created_at, id);

-- Every resource a run's renderer created or read (resources.list).
CREATE TABLE run_resources (
  id               INTEGER PRIMARY KEY,
  run_id           INTEGER NOT NULL REFERENCES runs (id) ON DELETE CASCADE,
  position         INTEGER NOT NULL,
  name             TEXT NOT NULL,
  kind             TEXT NOT NULL,
  format           TEXT,
  element_bytes    INTEGER,
  width            INTEGER,
  height           INTEGER,
  allocation_bytes INTEGER,
  format_bytes     INTEGER,
  usage            TEXT,
  UNIQUE (run_id, position)
);

CREATE TABLE screenshots (
  id     INTEGER PRIMARY KEY,
  name   TEXT NOT NULL,           -- the file name the capture gave it
  png    BLOB NOT NULL,
  width  INTEGER NOT NULL,
  height INTEGER NOT NULL
);

-- One camera of a run. sky_fraction is NULL when the renderer has no skybox
-- pass (-1 in the result); psnr is NULL when the images are identical.
CREATE TABLE samples (
  id                    INTEGER PRIMARY KEY,
  run_id                INTEGER NOT NULL REFERENCES runs (id) ON DELETE CASCADE,
  camera_index          INTEGER NOT NULL,
  camera                TEXT NOT NULL CHECK (json_valid(camera)),
  sky_fraction          REAL,
  sky_fraction_estimate REAL,
  frames                INTEGER,
  frame_ms              REAL NOT NULL,
  frame_ms_spread       TEXT CHECK (frame_ms_spread IS NULL OR json_valid(frame_ms_spread)),
  frame_ms_instrumented REAL,
  overhead_ratio        REAL,
  bytes                 REAL NOT NULL DEFAULT 0,  -- all counters of the sample, per frame
  image_against         TEXT,     -- NULL when the sample was not compared
  image_identical       INTEGER,
  psnr                  REAL,
  max_abs               REAL,
  mean_abs              REAL,
  screenshot_id         INTEGER REFERENCES screenshots (id) ON DELETE SET NULL,
  UNIQUE (run_id, camera_index)   -- also the samples-by-run index
);
CREATE INDEX samples_by_screenshot ON samples (screenshot_id);

CREATE TABLE passes (
  id                             INTEGER PRIMARY KEY,
  sample_id                      INTEGER NOT NULL REFERENCES samples (id) ON DELETE CASCADE,
  position                       INTEGER NOT NULL,   -- order within the frame
  name                           TEXT NOT NULL,
  gpu_ms                         REAL NOT NULL,
  gpu_ms_spread                  TEXT CHECK (gpu_ms_spread IS NULL OR json_valid(gpu_ms_spread)),
  gpu_ms_instrumented            REAL,
  overhead_ratio                 REAL,
  fragment_invocations           REAL,
  fragment_invocations_statistic REAL,
  UNIQUE (sample_id, position)    -- also the passes-by-sample index
);

-- Traffic of one pass on one resource, one access kind.
CREATE TABLE counters (
  id           INTEGER PRIMARY KEY,
  pass_id      INTEGER NOT NULL REFERENCES passes (id) ON DELETE CASCADE,
  position     INTEGER NOT NULL,
  resource     TEXT NOT NULL,
  kind         TEXT,
  format       TEXT,
  access       TEXT NOT NULL CHECK (access IN ('read', 'write')),
  count        REAL NOT NULL,
  bytes        REAL NOT NULL,
  count_spread TEXT CHECK (count_spread IS NULL OR json_valid(count_spread)),
  source       TEXT NOT NULL,
  UNIQUE (pass_id, position)      -- also the counters-by-pass index
);
