#!/usr/bin/python3
"""The throwaway PostgreSQL server of tests/support/pgserver.py, through psql:
two databases, each seeing only its own table, and stop() leaving no server
behind. Exits 77 (skipped) without PostgreSQL, except where tests are strict (strict.py).

  pgserver_test.py
"""
import os
import sys

sys.dont_write_bytecode = True  # no __pycache__ in the source tree
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from pgserver import PostgresError, PostgresServer, _alive, require_postgres  # noqa: E402

failures = []


def check(ok, what):
    print(("ok: " if ok else "FAIL: ") + what)
    if not ok:
        failures.append(what)


pg = require_postgres()
check(pg.url() == f"postgresql://tally@127.0.0.1:{pg.port}/tally", "url() names the database tally")
url_a = pg.create_database("separate_a")
pg.create_database()  # test_1
check(url_a == pg.url("separate_a"), "create_database returns the database's url")
pg.psql("separate_a", "CREATE TABLE only_in_a (id integer)")
pg.psql("test_1", "CREATE TABLE only_in_b (id integer)")
tables = "SELECT table_name FROM information_schema.tables WHERE table_schema = 'public'"
check(pg.psql("separate_a", tables) == "only_in_a\n", "separate_a sees only its own table")
check(pg.psql("test_1", tables) == "only_in_b\n", "test_1 sees only its own table")
try:
    pg.create_database("separate_a")
    check(False, "a taken name is refused")
except PostgresError:
    check(True, "a taken name is refused")

# A server of its own, stopped: its postmaster gone, its folder removed.
with PostgresServer() as own:
    data_dir = own.data_dir
    with open(os.path.join(data_dir, "postmaster.pid")) as f:
        pid = int(f.readline())
    check(_alive(pid), f"postmaster {pid} runs")
    check(own.psql("tally", "SELECT 1") == "1\n", "psql reaches the server")
check(not own.running, "stopped at the end of the with block")
check(not _alive(pid), f"postmaster {pid} of {data_dir} gone after stop()")
check(not os.path.exists(data_dir), "its folder removed")
own.stop()  # a second stop does nothing

try:
    PostgresServer(bindir="/nonexistent/postgresql/bin").start()
    check(False, "missing binaries are reported")
except PostgresError as e:
    check("PostgreSQL is not installed" in str(e), "missing binaries are reported")

print(f"{len(failures)} failure(s)" if failures else "all ok")
sys.exit(1 if failures else 0)
