-- A fleet of capture hosts sharing one store (docs/fleet.md): the hosts that
-- run captures, and what the queue needs to survive them. Applied after
-- 0006_footprint in one transaction, which then sets PRAGMA user_version = 7.
-- Never edit a released migration.

-- One daemon that runs captures (role worker or all), by its host name.
-- instance is random per process: a second live daemon under the same name
-- is refused. Times in milliseconds since 1970 are the database's clock, so
-- hosts with skewed clocks still agree on leases.
CREATE TABLE hosts (
  id                INTEGER PRIMARY KEY,
  name              TEXT NOT NULL UNIQUE,
  instance          TEXT NOT NULL,
  role              TEXT NOT NULL CHECK (role IN ('worker', 'all')),
  device            TEXT CHECK (device IS NULL OR json_valid(device)),  -- the result-style device object
  device_override   TEXT,   -- the device name reported instead of the real one (tests, sites)
  tally_version     TEXT NOT NULL,
  tally_commit      TEXT NOT NULL,
  started_at        TEXT NOT NULL DEFAULT (strftime('%Y-%m-%dT%H:%M:%fZ', 'now')),
  heartbeat_ms      INTEGER NOT NULL,
  jobs_done         INTEGER NOT NULL DEFAULT 0,
  jobs_failed       INTEGER NOT NULL DEFAULT 0,
  current_job       INTEGER
);

-- The queue across hosts. host: the host that holds the job (running) or
-- last held it; lease_expires_ms: when the holder's lease ends unless renewed;
-- max_attempts: claims allowed before the job fails; attempt_errors: a JSON
-- array, one line per attempt that did not finish (why); device_requirement:
-- the spec's "device", normalised ({"name", "vendor", "features"}), NULL for any.
ALTER TABLE jobs ADD COLUMN host TEXT;
ALTER TABLE jobs ADD COLUMN lease_expires_ms INTEGER;
ALTER TABLE jobs ADD COLUMN max_attempts INTEGER NOT NULL DEFAULT 3 CHECK (max_attempts >= 1);
ALTER TABLE jobs ADD COLUMN attempt_errors TEXT NOT NULL DEFAULT '[]' CHECK (json_valid(attempt_errors));
ALTER TABLE jobs ADD COLUMN device_requirement TEXT
  CHECK (device_requirement IS NULL OR json_valid(device_requirement));
-- Expired leases are found by status and time.
CREATE INDEX jobs_by_lease ON jobs (status, lease_expires_ms);

-- The host each run was captured on; NULL for runs stored before.
ALTER TABLE runs ADD COLUMN host TEXT;
CREATE INDEX runs_by_host ON runs (host, id);
