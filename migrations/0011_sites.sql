-- Sites, draws and materials (docs/result-schema.md, "Sites, draws and
-- materials"): where in the shader, and in which draw and material, a pass's
-- bytes go. Rows exist only for results captured with per-site counting
-- ("sites": true, or the layer's --sites). Counts and bytes are per frame,
-- averaged over the sample's counted frames, like counters. Applied after
-- 0010_job_client in one transaction, which then sets PRAGMA user_version = 11.
-- Never edit a released migration.

-- One access site (an image or buffer access instruction) of a pass's
-- instrumented shaders. position: its order in the result. line is NULL where
-- the module carries no line information; instruction is NULL where the
-- module's text gave none (an application's module without result ids).
-- At most 4096 sites per pass (ingest refuses more).
CREATE TABLE pass_sites (
  pass_id     INTEGER NOT NULL REFERENCES passes (id) ON DELETE CASCADE,
  position    INTEGER NOT NULL,
  shader      TEXT NOT NULL,
  stage       TEXT NOT NULL,
  entry_point TEXT NOT NULL,
  instruction INTEGER CHECK (instruction IS NULL OR instruction >= 0),
  opcode      TEXT NOT NULL,
  resource    TEXT NOT NULL,
  access      TEXT NOT NULL CHECK (access IN ('read', 'write')),
  kind        TEXT,
  file        TEXT,
  line        INTEGER CHECK (line IS NULL OR line >= 1),
  disassembly TEXT NOT NULL,
  count       REAL NOT NULL CHECK (count >= 0),
  bytes       REAL NOT NULL CHECK (bytes >= 0),
  PRIMARY KEY (pass_id, position)
);
-- The ranked reads (GET /api/samples/{id}/sites, tally hotspots).
CREATE INDEX pass_sites_by_bytes ON pass_sites (pass_id, bytes DESC);

-- A pass's heaviest draws, at most 256, ranked by bytes (rank 0 the heaviest).
-- draw_index: the draw's position in the frame (recording order for the layer).
-- mesh and material are NULL for the layer's draws.
CREATE TABLE pass_draws (
  pass_id       INTEGER NOT NULL REFERENCES passes (id) ON DELETE CASCADE,
  rank          INTEGER NOT NULL CHECK (rank >= 0 AND rank < 256),
  draw_index    INTEGER NOT NULL CHECK (draw_index >= 0),
  name          TEXT NOT NULL,
  mesh          TEXT,
  material      TEXT,
  count         REAL NOT NULL CHECK (count >= 0),
  bytes_read    REAL NOT NULL CHECK (bytes_read >= 0),
  bytes_written REAL NOT NULL CHECK (bytes_written >= 0),
  bytes         REAL NOT NULL CHECK (bytes >= 0),
  PRIMARY KEY (pass_id, rank)
);

-- The draws beyond the 256 kept, summed into one line (no row: no rest).
CREATE TABLE pass_draws_rest (
  pass_id       INTEGER PRIMARY KEY REFERENCES passes (id) ON DELETE CASCADE,
  draws         INTEGER NOT NULL CHECK (draws >= 1),
  count         REAL NOT NULL CHECK (count >= 0),
  bytes_read    REAL NOT NULL CHECK (bytes_read >= 0),
  bytes_written REAL NOT NULL CHECK (bytes_written >= 0),
  bytes         REAL NOT NULL CHECK (bytes >= 0)
);

-- A pass's bytes per material, summed by the capture from all its draws (the
-- rest included, so they cannot be derived from pass_draws), ranked by bytes.
-- At most 4096 per pass.
CREATE TABLE pass_materials (
  pass_id       INTEGER NOT NULL REFERENCES passes (id) ON DELETE CASCADE,
  rank          INTEGER NOT NULL CHECK (rank >= 0),
  material      TEXT NOT NULL,
  draws         INTEGER NOT NULL CHECK (draws >= 0),
  bytes_read    REAL NOT NULL CHECK (bytes_read >= 0),
  bytes_written REAL NOT NULL CHECK (bytes_written >= 0),
  bytes         REAL NOT NULL CHECK (bytes >= 0),
  PRIMARY KEY (pass_id, rank)
);

-- Shader source texts, stored once per content: runs of one build share them.
-- hash: the text's 64-bit FNV-1a in hex, as the result's "shaders" gives it;
-- a lookup compares the text too, so two texts of one hash stay apart.
-- At most 1 MiB of text each. Texts stay when the runs naming them are replaced.
CREATE TABLE shader_sources (
  id     INTEGER PRIMARY KEY,
  hash   TEXT NOT NULL,
  text   TEXT NOT NULL,
  length INTEGER NOT NULL CHECK (length >= 0 AND length <= 1048576)
);
CREATE INDEX shader_sources_by_hash ON shader_sources (hash);

-- The sources a run's result carried (runs[].shader_sources), by name (the
-- name its sites' "shader" gives). At most 256 per run.
CREATE TABLE run_shaders (
  run_id    INTEGER NOT NULL REFERENCES runs (id) ON DELETE CASCADE,
  name      TEXT NOT NULL,
  source_id INTEGER NOT NULL REFERENCES shader_sources (id),
  PRIMARY KEY (run_id, name)
);
CREATE INDEX run_shaders_by_source ON run_shaders (source_id);
