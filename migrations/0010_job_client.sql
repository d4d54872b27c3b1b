-- Who queued each job, for the per-client queue limit (tallyd serve
-- --max-queued-per-client; docs/operating.md, "Limits"). Applied after
-- 0009_alerts in one transaction, which then sets PRAGMA user_version = 10.
-- Never edit a released migration.

-- "token:capture" (the token the request carried) or "peer:<address>" (a
-- daemon without tokens); NULL for jobs queued before this migration and for
-- jobs created outside the API (they count towards no client).
ALTER TABLE jobs ADD COLUMN client TEXT;
CREATE INDEX jobs_by_client ON jobs (client, status);
