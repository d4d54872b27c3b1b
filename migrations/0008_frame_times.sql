-- Per-frame times (docs/result-schema.md): every uninstrumented frame's time
-- of a sample, and every pass's time in those frames, in frame order. Applied
-- after 0007_fleet in one transaction, which then sets PRAGMA user_version = 8.
-- Never edit a released migration.

-- JSON arrays of milliseconds, one entry per frame; NULL for samples and
-- passes stored before, or ingested from results without them.
ALTER TABLE samples ADD COLUMN frame_ms_frames TEXT
  CHECK (frame_ms_frames IS NULL OR json_valid(frame_ms_frames));
ALTER TABLE passes ADD COLUMN gpu_ms_frames TEXT
  CHECK (gpu_ms_frames IS NULL OR json_valid(gpu_ms_frames));
