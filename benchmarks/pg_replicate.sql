-- Grows a PostgreSQL benchmark database that tally_bench_read_latency filled
-- through the store (e.g. 100k samples) to COPIES times its size, by copying
-- every job, run, resource, screenshot, sample and pass (its counters with it:
-- they are arrays on the pass's row, migration 0012) with its ids
-- shifted past the largest ones, in SQL on the server: a 1M-sample database
-- in minutes instead of the 40 of a fill through the store at ~400 samples/s
-- (docs/benchmarks.md, "Fleet"). The copies keep the originals' values
-- (renderers, scenes, devices, times, creation dates), so filters match COPIES
-- times the rows, as in a fill of that size. Devices and scenes are shared.
--
--   psql -v copies=10 -h HOST -p PORT -U tally -d bench -f benchmarks/pg_replicate.sql
\set ON_ERROR_STOP on
SELECT set_config('tally.copies', :'copies', false);

DO $$
DECLARE
  copies int := current_setting('tally.copies')::int;
  -- The largest id of each table before copying: copy k's ids are id + k * max.
  mj bigint := (SELECT max(id) FROM jobs);
  mr bigint := (SELECT max(id) FROM runs);
  mrr bigint := (SELECT max(id) FROM run_resources);
  msh bigint := COALESCE((SELECT max(id) FROM screenshots), 0);
  ms bigint := (SELECT max(id) FROM samples);
  mp bigint := (SELECT max(id) FROM passes);
  shift text;
  cols text;
  exprs text;
  t text;
BEGIN
  IF copies < 2 THEN RAISE EXCEPTION 'copies must be at least 2, got %', copies; END IF;
  FOR k IN 1 .. copies - 1 LOOP
    FOREACH t IN ARRAY ARRAY['jobs', 'runs', 'run_resources', 'screenshots', 'samples', 'passes'] LOOP
      -- Every column as it is, but ids and the references between the copied tables.
      SELECT string_agg(quote_ident(column_name), ', ' ORDER BY ordinal_position),
             string_agg(CASE
                          WHEN column_name = 'id' THEN format('id + %s', k * CASE t
                              WHEN 'jobs' THEN mj WHEN 'runs' THEN mr WHEN 'run_resources' THEN mrr
                              WHEN 'screenshots' THEN msh WHEN 'samples' THEN ms WHEN 'passes' THEN mp
                              ELSE mp END)
                          WHEN column_name = 'job_id' THEN format('job_id + %s', k * mj)
                          WHEN column_name = 'run_id' THEN format('run_id + %s', k * mr)
                          WHEN column_name = 'screenshot_id' THEN format('screenshot_id + %s', k * msh)
                          WHEN column_name = 'sample_id' THEN format('sample_id + %s', k * ms)
                          WHEN column_name = 'pass_id' THEN format('pass_id + %s', k * mp)
                          WHEN t = 'jobs' AND column_name = 'idempotency_key' THEN 'NULL'
                          ELSE quote_ident(column_name) END, ', ' ORDER BY ordinal_position)
        INTO cols, exprs
        FROM information_schema.columns
       WHERE table_schema = current_schema() AND table_name = t;
      shift := CASE t WHEN 'jobs' THEN mj WHEN 'runs' THEN mr WHEN 'run_resources' THEN mrr
                      WHEN 'screenshots' THEN msh WHEN 'samples' THEN ms ELSE mp END;
      EXECUTE format('INSERT INTO %I (%s) SELECT %s FROM %I WHERE id <= %s', t, cols, exprs, t, shift);
    END LOOP;
    RAISE NOTICE 'copy % of % done', k + 1, copies;
  END LOOP;
  -- The identity columns continue after the copies.
  FOREACH t IN ARRAY ARRAY['jobs', 'runs', 'run_resources', 'screenshots', 'samples', 'passes'] LOOP
    EXECUTE format('SELECT setval(pg_get_serial_sequence(%L, ''id''), (SELECT max(id) FROM %I))', t, t);
  END LOOP;
END $$;

ANALYZE;
