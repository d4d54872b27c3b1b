-- Labels, baselines and regression alerts (docs/statistics.md, "Alerts";
-- docs/api.md, "Baselines and alerts"). Applied after 0008_frame_times in one
-- transaction, which then sets PRAGMA user_version = 9. Never edit a released
-- migration.

-- A capture's labels ({"commit": "4f2a9c1", "branch": "main"}), as its spec
-- gave them: the whole object on the job, and one row per label to filter
-- runs by (GET /api/runs?label=commit=4f2a9c1).
ALTER TABLE jobs ADD COLUMN labels TEXT NOT NULL DEFAULT '{}' CHECK (json_valid(labels));
CREATE TABLE job_labels (
  job_id  INTEGER NOT NULL REFERENCES jobs (id) ON DELETE CASCADE,
  name    TEXT NOT NULL,
  value   TEXT NOT NULL,
  PRIMARY KEY (job_id, name)
);
CREATE INDEX job_labels_by_value ON job_labels (name, value, job_id);

-- Whether the alert evaluator has tested the run against its configuration's
-- baseline (0: not yet). Runs stored before this migration are not tested.
ALTER TABLE runs ADD COLUMN evaluated INTEGER NOT NULL DEFAULT 0 CHECK (evaluated IN (0, 1));
UPDATE runs SET evaluated = 1;
CREATE INDEX runs_to_evaluate ON runs (evaluated, id);

-- A configuration's baseline run: renderer and canonical options, scene (and
-- its parameters, through scene_id), resolution, device and counting mode.
-- Lights and labels are not part of it. At most one active baseline per
-- configuration; setting another marks this one replaced (replaced_by), and
-- DELETE marks it removed: its alerts stay.
CREATE TABLE baselines (
  id          INTEGER PRIMARY KEY,
  name        TEXT,
  run_id      INTEGER NOT NULL REFERENCES runs (id) ON DELETE CASCADE,
  renderer    TEXT NOT NULL,
  options     TEXT NOT NULL DEFAULT '{}' CHECK (json_valid(options)),
  scene_id    INTEGER NOT NULL REFERENCES scenes (id),
  width       INTEGER NOT NULL,
  height      INTEGER NOT NULL,
  device_id   INTEGER NOT NULL REFERENCES devices (id),
  counting    TEXT NOT NULL,
  threshold   REAL NOT NULL CHECK (threshold >= 0),   -- |ratio - 1| beyond which a significant time change alerts
  status      TEXT NOT NULL DEFAULT 'active' CHECK (status IN ('active', 'replaced', 'removed')),
  created_at  TEXT NOT NULL DEFAULT (strftime('%Y-%m-%dT%H:%M:%fZ', 'now')),
  ended_at    TEXT,                                  -- when it was replaced or removed
  replaced_by INTEGER REFERENCES baselines (id) ON DELETE SET NULL
);
CREATE UNIQUE INDEX baselines_one_active ON baselines (renderer, options, scene_id, width, height, device_id, counting)
  WHERE status = 'active';
CREATE INDEX baselines_by_run ON baselines (run_id);

-- One change of a run against its baseline's run. kind time: metric "frame"
-- or "pass NAME", verdict slower | faster, with the comparison's figures
-- (ratio of medians B / A, its interval, Mann-Whitney p, Cliff's delta,
-- medians in ms). kind counts: metric "counts", verdict changed, value_a and
-- value_b the runs' total bytes per frame; details lists every line that
-- changed. The delivery columns are the webhook's outbox: none (no webhook
-- when it was raised), pending, delivered or failed (attempts used up).
CREATE TABLE alerts (
  id                INTEGER PRIMARY KEY,
  baseline_id       INTEGER NOT NULL REFERENCES baselines (id) ON DELETE CASCADE,
  run_id            INTEGER NOT NULL REFERENCES runs (id) ON DELETE CASCADE,
  baseline_run_id   INTEGER NOT NULL,
  kind              TEXT NOT NULL CHECK (kind IN ('time', 'counts')),
  metric            TEXT NOT NULL,
  verdict           TEXT NOT NULL CHECK (verdict IN ('slower', 'faster', 'changed')),
  ratio             REAL,
  ratio_lower       REAL,
  ratio_upper       REAL,
  p_value           REAL,
  cliffs_delta      REAL,
  value_a           REAL,
  value_b           REAL,
  details           TEXT NOT NULL DEFAULT '{}' CHECK (json_valid(details)),
  status            TEXT NOT NULL DEFAULT 'open' CHECK (status IN ('open', 'acknowledged', 'invalid', 'fixed')),
  created_at        TEXT NOT NULL DEFAULT (strftime('%Y-%m-%dT%H:%M:%fZ', 'now')),
  updated_at        TEXT,
  delivery          TEXT NOT NULL DEFAULT 'none' CHECK (delivery IN ('none', 'pending', 'delivered', 'failed')),
  delivery_attempts INTEGER NOT NULL DEFAULT 0,
  next_attempt_ms   INTEGER,   -- ms since 1970 (the database's clock): the next try, or the claim's end
  delivery_error    TEXT,      -- the last attempt's failure
  delivered_at      TEXT
);
CREATE INDEX alerts_by_status ON alerts (status, id);
CREATE INDEX alerts_by_baseline ON alerts (baseline_id, id);
CREATE INDEX alerts_by_run ON alerts (run_id, id);
CREATE INDEX alerts_to_deliver ON alerts (delivery, next_attempt_ms);
