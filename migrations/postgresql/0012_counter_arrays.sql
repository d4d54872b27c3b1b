-- A pass's counters as arrays on the pass's own row, and `counters` a view
-- that unnests them: the same columns (but the unused id) and the same rows,
-- in the same order, so every query that reads counters reads them as before.
-- SQLite keeps its counters table (migrations/0012_counter_arrays.sql).
--
-- Why: at 25 counters per sample, counter rows were most of PostgreSQL's
-- ingest. COPY of 126,000 rows into counters, each with its identity, its
-- two indexes and its foreign key checked row by row, took 2.3 s; the same
-- counters as arrays on their 19,000 passes added 0.7 to 1.0 s to the passes'
-- own 0.3 s (docs/benchmarks.md, "Counters as arrays on their pass").
--
-- Element k of every counter_* array is the pass's counter at position k
-- (the result's order): all arrays have one element per counter, one
-- dimension, and the NOT NULL columns of the old table have no NULL element.
-- The old table's check that count_spread is JSON is not kept: casting each
-- element to jsonb took a third of the passes' COPY, and the store writes
-- spreads only as it serialises JSON it parsed (server/store/ingest_capture.cpp).
-- Never edit a released migration.

ALTER TABLE passes
  ADD COLUMN counter_resources  TEXT[] COLLATE "C" NOT NULL DEFAULT '{}',
  ADD COLUMN counter_kinds      TEXT[] COLLATE "C" NOT NULL DEFAULT '{}',
  ADD COLUMN counter_formats    TEXT[] COLLATE "C" NOT NULL DEFAULT '{}',
  ADD COLUMN counter_accesses   TEXT[] COLLATE "C" NOT NULL DEFAULT '{}',
  ADD COLUMN counter_counts     DOUBLE PRECISION[] NOT NULL DEFAULT '{}',
  ADD COLUMN counter_bytes      DOUBLE PRECISION[] NOT NULL DEFAULT '{}',
  ADD COLUMN counter_spreads    TEXT[] COLLATE "C" NOT NULL DEFAULT '{}',
  ADD COLUMN counter_sources    TEXT[] COLLATE "C" NOT NULL DEFAULT '{}',
  ADD COLUMN counter_footprints DOUBLE PRECISION[] NOT NULL DEFAULT '{}';

UPDATE passes p
   SET counter_resources = c.resources, counter_kinds = c.kinds, counter_formats = c.formats,
       counter_accesses = c.accesses, counter_counts = c.counts, counter_bytes = c.bytes,
       counter_spreads = c.spreads, counter_sources = c.sources, counter_footprints = c.footprints
  FROM (SELECT pass_id,
               array_agg(resource ORDER BY position) AS resources,
               array_agg(kind ORDER BY position) AS kinds,
               array_agg(format ORDER BY position) AS formats,
               array_agg(access ORDER BY position) AS accesses,
               array_agg(count ORDER BY position) AS counts,
               array_agg(bytes ORDER BY position) AS bytes,
               array_agg(count_spread ORDER BY position) AS spreads,
               array_agg(source ORDER BY position) AS sources,
               array_agg(footprint_bytes ORDER BY position) AS footprints
          FROM counters GROUP BY pass_id) c
 WHERE c.pass_id = p.id;

ALTER TABLE passes ADD CONSTRAINT passes_counters_check CHECK (
  COALESCE(array_ndims(counter_resources), 1) = 1
  AND COALESCE(array_ndims(counter_kinds), 1) = 1 AND cardinality(counter_kinds) = cardinality(counter_resources)
  AND COALESCE(array_ndims(counter_formats), 1) = 1 AND cardinality(counter_formats) = cardinality(counter_resources)
  AND COALESCE(array_ndims(counter_accesses), 1) = 1 AND cardinality(counter_accesses) = cardinality(counter_resources)
  AND COALESCE(array_ndims(counter_counts), 1) = 1 AND cardinality(counter_counts) = cardinality(counter_resources)
  AND COALESCE(array_ndims(counter_bytes), 1) = 1 AND cardinality(counter_bytes) = cardinality(counter_resources)
  AND COALESCE(array_ndims(counter_spreads), 1) = 1 AND cardinality(counter_spreads) = cardinality(counter_resources)
  AND COALESCE(array_ndims(counter_sources), 1) = 1 AND cardinality(counter_sources) = cardinality(counter_resources)
  AND COALESCE(array_ndims(counter_footprints), 1) = 1 AND cardinality(counter_footprints) = cardinality(counter_resources)
  AND array_position(counter_resources, NULL) IS NULL
  AND array_position(counter_counts, NULL) IS NULL
  AND array_position(counter_bytes, NULL) IS NULL
  AND array_position(counter_sources, NULL) IS NULL
  AND counter_accesses <@ ARRAY['read', 'write']::TEXT[]
  AND COALESCE(0 <= ALL (counter_footprints), TRUE));

-- No query filters or groups by an array: ANALYZE skips them (their element
-- statistics made it 2.3 times as long).
ALTER TABLE passes ALTER COLUMN counter_resources SET STATISTICS 0;
ALTER TABLE passes ALTER COLUMN counter_kinds SET STATISTICS 0;
ALTER TABLE passes ALTER COLUMN counter_formats SET STATISTICS 0;
ALTER TABLE passes ALTER COLUMN counter_accesses SET STATISTICS 0;
ALTER TABLE passes ALTER COLUMN counter_counts SET STATISTICS 0;
ALTER TABLE passes ALTER COLUMN counter_bytes SET STATISTICS 0;
ALTER TABLE passes ALTER COLUMN counter_spreads SET STATISTICS 0;
ALTER TABLE passes ALTER COLUMN counter_sources SET STATISTICS 0;
ALTER TABLE passes ALTER COLUMN counter_footprints SET STATISTICS 0;

DROP TABLE counters;

-- The old table's columns but id: pass_id, position (0, 1, ... in the
-- result's order), resource, kind, format, access, count, bytes,
-- count_spread, source, footprint_bytes.
CREATE VIEW counters AS
SELECT p.id AS pass_id, c.ordinality - 1 AS position, c.resource, c.kind, c.format, c.access, c.count,
       c.bytes, c.count_spread, c.source, c.footprint_bytes
  FROM passes p
 CROSS JOIN LATERAL unnest(p.counter_resources, p.counter_kinds, p.counter_formats, p.counter_accesses,
                           p.counter_counts, p.counter_bytes, p.counter_spreads, p.counter_sources,
                           p.counter_footprints)
       WITH ORDINALITY AS c (resource, kind, format, access, count, bytes, count_spread, source,
                             footprint_bytes, ordinality);
