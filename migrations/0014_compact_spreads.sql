-- Count spreads whose frames all counted the counter's count are stored as
-- the number of frames alone (server/store/count_spread.hpp); every other
-- spread as before. No table changes on SQLite: the version itself is the
-- point. A daemon refuses a database newer than it knows, so one built
-- before this, which would hand such a number to its readers as the
-- spread, never reads what a newer one wrote. Applied after
-- 0013_run_summary in one transaction, which then sets PRAGMA
-- user_version = 14. Never edit a released migration.
SELECT 1;
