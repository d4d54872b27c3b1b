-- Footprint (docs/result-schema.md, "Footprint"; docs/measurement.md): the
-- distinct bytes each access line touched per frame, counted in blocks,
-- beside the bytes it requested (counters.bytes). NULL for lines, samples and
-- runs stored before, captured with footprint off, or a line the model cannot
-- see. Applied after 0005_tally_version in one transaction, which then sets
-- PRAGMA user_version = 6. Never edit a released migration.

-- The run's block size in bytes (the spec's "footprint": 32, 64 or 128).
ALTER TABLE runs ADD COLUMN footprint_block_bytes INTEGER
  CHECK (footprint_block_bytes IS NULL OR footprint_block_bytes IN (32, 64, 128));

-- A line's footprint per frame, averaged over the sample's counted frames.
ALTER TABLE counters ADD COLUMN footprint_bytes REAL CHECK (footprint_bytes IS NULL OR footprint_bytes >= 0);

-- The sample's footprint (the sum over its lines that have one) and the
-- requested bytes of those same lines, so that reuse (requested / footprint)
-- compares like with like; both NULL when no line has a footprint. Set by
-- ingest from the counters, as samples.bytes is.
ALTER TABLE samples ADD COLUMN footprint_bytes REAL;
ALTER TABLE samples ADD COLUMN footprint_requested_bytes REAL;
