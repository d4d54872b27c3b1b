-- The ingest's four busiest foreign keys, checked once per statement instead
-- of once per row. Never edit a released migration.
--
--   passes.sample_id      -> samples      ON DELETE CASCADE
--   samples.run_id        -> runs         ON DELETE CASCADE
--   samples.screenshot_id -> screenshots  ON DELETE SET NULL
--   run_resources.run_id  -> runs         ON DELETE CASCADE
--
-- Why: a foreign key checks each new row with a query of its own (an
-- executor started and ended per row) when the statement ends. A capture of
-- 200 samples writes about 1,700 such rows, and at 20,000 samples the checks
-- were a fifth of PostgreSQL's ingest time (docs/benchmarks.md, "Foreign
-- keys checked per statement"). Here, after each statement that adds or
-- changes child rows, one query finds and locks every parent they name; after
-- each statement that deletes parents, one statement deletes (or lets go of)
-- their children, found through the child's index on the column.
--
-- What a foreign key did, this does:
--   - a child row naming a parent that does not exist is refused, with
--     SQLSTATE 23503 (foreign_key_violation) and the key in the detail;
--   - the parents found are locked FOR KEY SHARE until the transaction ends,
--     as a foreign key's check locks them, so that no other transaction
--     deletes them meanwhile (one that deleted them first makes the check fail);
--   - deleting a parent deletes its children, or sets the screenshot NULL;
--   - a parent's id never changes under its children: ids of runs, samples
--     and screenshots cannot change at all (nothing changes them).
-- TRUNCATE of a parent is not followed; nothing truncates these tables.
-- SQLite keeps its foreign keys (migrations/0015_statement_references.sql).

ALTER TABLE passes DROP CONSTRAINT IF EXISTS passes_sample_id_fkey;
ALTER TABLE samples
  DROP CONSTRAINT IF EXISTS samples_run_id_fkey,
  DROP CONSTRAINT IF EXISTS samples_screenshot_id_fkey;
ALTER TABLE run_resources DROP CONSTRAINT IF EXISTS run_resources_run_id_fkey;

-- After a statement that added or changed rows of a child table (its rows:
-- the transition table `added`): every parent that they name exists, locked.
-- TG_ARGV: the child's column, the parent table (whose key is id).
CREATE FUNCTION tally_parents_exist() RETURNS trigger LANGUAGE plpgsql AS $$
DECLARE
  wanted BIGINT[];
  found BIGINT;
  missing BIGINT;
BEGIN
  EXECUTE format('SELECT array_agg(DISTINCT %I) FROM added WHERE %I IS NOT NULL', TG_ARGV[0], TG_ARGV[0])
    INTO wanted;
  IF wanted IS NULL THEN
    RETURN NULL;
  END IF;
  EXECUTE format('SELECT count(*) FROM (SELECT 1 FROM %I WHERE id = ANY ($1) FOR KEY SHARE) parents', TG_ARGV[1])
    INTO found USING wanted;
  IF found < cardinality(wanted) THEN
    EXECUTE format('SELECT w FROM unnest($1) w WHERE NOT EXISTS (SELECT 1 FROM %I p WHERE p.id = w) LIMIT 1',
                   TG_ARGV[1])
      INTO missing USING wanted;
    RAISE EXCEPTION 'insert or update on table "%" violates foreign key constraint "%_%_fkey"',
                    TG_TABLE_NAME, TG_TABLE_NAME, TG_ARGV[0]
      USING ERRCODE = 'foreign_key_violation', TABLE = TG_TABLE_NAME, COLUMN = TG_ARGV[0],
            DETAIL = format('Key (%s)=(%s) is not present in table "%s".', TG_ARGV[0], missing, TG_ARGV[1]);
  END IF;
  RETURN NULL;
END
$$;

-- After a statement that deleted rows of a parent table (its rows: the
-- transition table `gone`): their children are deleted ('cascade') or let
-- go of them ('set null'). TG_ARGV: the child table, its column, the action.
CREATE FUNCTION tally_children_follow() RETURNS trigger LANGUAGE plpgsql AS $$
DECLARE
  ids BIGINT[];
BEGIN
  SELECT array_agg(id) INTO ids FROM gone;
  IF ids IS NULL THEN
    RETURN NULL;
  END IF;
  IF TG_ARGV[2] = 'cascade' THEN
    EXECUTE format('DELETE FROM %I WHERE %I = ANY ($1)', TG_ARGV[0], TG_ARGV[1]) USING ids;
  ELSE
    EXECUTE format('UPDATE %I SET %I = NULL WHERE %I = ANY ($1)', TG_ARGV[0], TG_ARGV[1], TG_ARGV[1]) USING ids;
  END IF;
  RETURN NULL;
END
$$;

-- Before a row's id changes: refused (its children would lose it).
CREATE FUNCTION tally_id_is_fixed() RETURNS trigger LANGUAGE plpgsql AS $$
BEGIN
  RAISE EXCEPTION 'update on table "%" changes the id % to %: ids of % never change', TG_TABLE_NAME, OLD.id, NEW.id,
                  TG_TABLE_NAME
    USING ERRCODE = 'foreign_key_violation', TABLE = TG_TABLE_NAME, COLUMN = 'id';
END
$$;

CREATE TRIGGER passes_sample_added AFTER INSERT ON passes REFERENCING NEW TABLE AS added
  FOR EACH STATEMENT EXECUTE FUNCTION tally_parents_exist('sample_id', 'samples');
CREATE TRIGGER passes_sample_changed AFTER UPDATE ON passes REFERENCING NEW TABLE AS added
  FOR EACH STATEMENT EXECUTE FUNCTION tally_parents_exist('sample_id', 'samples');
CREATE TRIGGER samples_run_added AFTER INSERT ON samples REFERENCING NEW TABLE AS added
  FOR EACH STATEMENT EXECUTE FUNCTION tally_parents_exist('run_id', 'runs');
CREATE TRIGGER samples_run_changed AFTER UPDATE ON samples REFERENCING NEW TABLE AS added
  FOR EACH STATEMENT EXECUTE FUNCTION tally_parents_exist('run_id', 'runs');
CREATE TRIGGER samples_screenshot_added AFTER INSERT ON samples REFERENCING NEW TABLE AS added
  FOR EACH STATEMENT EXECUTE FUNCTION tally_parents_exist('screenshot_id', 'screenshots');
CREATE TRIGGER samples_screenshot_changed AFTER UPDATE ON samples REFERENCING NEW TABLE AS added
  FOR EACH STATEMENT EXECUTE FUNCTION tally_parents_exist('screenshot_id', 'screenshots');
CREATE TRIGGER run_resources_run_added AFTER INSERT ON run_resources REFERENCING NEW TABLE AS added
  FOR EACH STATEMENT EXECUTE FUNCTION tally_parents_exist('run_id', 'runs');
CREATE TRIGGER run_resources_run_changed AFTER UPDATE ON run_resources REFERENCING NEW TABLE AS added
  FOR EACH STATEMENT EXECUTE FUNCTION tally_parents_exist('run_id', 'runs');

CREATE TRIGGER samples_deleted_passes AFTER DELETE ON samples REFERENCING OLD TABLE AS gone
  FOR EACH STATEMENT EXECUTE FUNCTION tally_children_follow('passes', 'sample_id', 'cascade');
CREATE TRIGGER runs_deleted_samples AFTER DELETE ON runs REFERENCING OLD TABLE AS gone
  FOR EACH STATEMENT EXECUTE FUNCTION tally_children_follow('samples', 'run_id', 'cascade');
CREATE TRIGGER runs_deleted_resources AFTER DELETE ON runs REFERENCING OLD TABLE AS gone
  FOR EACH STATEMENT EXECUTE FUNCTION tally_children_follow('run_resources', 'run_id', 'cascade');
CREATE TRIGGER screenshots_deleted_samples AFTER DELETE ON screenshots REFERENCING OLD TABLE AS gone
  FOR EACH STATEMENT EXECUTE FUNCTION tally_children_follow('samples', 'screenshot_id', 'set null');

CREATE TRIGGER runs_id_fixed BEFORE UPDATE OF id ON runs
  FOR EACH ROW WHEN (OLD.id IS DISTINCT FROM NEW.id) EXECUTE FUNCTION tally_id_is_fixed();
CREATE TRIGGER samples_id_fixed BEFORE UPDATE OF id ON samples
  FOR EACH ROW WHEN (OLD.id IS DISTINCT FROM NEW.id) EXECUTE FUNCTION tally_id_is_fixed();
CREATE TRIGGER screenshots_id_fixed BEFORE UPDATE OF id ON screenshots
  FOR EACH ROW WHEN (OLD.id IS DISTINCT FROM NEW.id) EXECUTE FUNCTION tally_id_is_fixed();
