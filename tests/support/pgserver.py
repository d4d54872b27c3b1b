"""A private, throwaway PostgreSQL server for Python tests: the Python twin of
postgres_server.hpp, standard library only (the server's own initdb, pg_ctl,
createdb and psql through subprocess).

Its own cluster in a temporary folder, listening on a free port of 127.0.0.1
only, superuser "tally" with trust authentication, fsync off; gone, folder
and all, at stop(), at the end of a with block, or at exit.

    with PostgresServer() as pg:
        url = pg.create_database("fleet")    # postgresql://tally@127.0.0.1:PORT/fleet
        pg.psql("fleet", "SELECT 1")          # "1\n"

A test script that needs one calls require_postgres(), which exits 77
(ctest's SKIP_RETURN_CODE) when PostgreSQL is missing, or 1 where tests are
strict (strict.py: CI=true, or scripts/test.sh).

The binaries are the installed server's (pg_config --bindir, else the highest
/usr/lib/postgresql/*/bin, else PATH). initdb and postgres refuse to run as
root, so under euid 0 they run as the "postgres" system user (Debian's
postgresql-common creates it) through setpriv, in a folder owned by it. A
watchdog (a detached shell) stops the server and removes the folder should
this process die without stop().
"""
import atexit
import os
import pwd
import shlex
import shutil
import signal
import socket
import stat
import subprocess
import sys
import tempfile
import time
import urllib.parse

from strict import SKIP, skip_or_fail  # SKIP: ctest's SKIP_RETURN_CODE for the tests that use this

SERVER_USER = "postgres"  # who initdb and postgres run as under root


class PostgresError(RuntimeError):
    """The server cannot start (PostgreSQL missing, initdb or pg_ctl failing),
    or refused a command."""


def _has_server_programs(bindir):
    return all(os.access(os.path.join(bindir, p), os.X_OK) for p in ("initdb", "pg_ctl"))


def find_bindir():
    """The folder of initdb and pg_ctl: pg_config --bindir, else the highest
    /usr/lib/postgresql/VERSION/bin, else initdb's on PATH; None if none."""
    try:
        out = subprocess.run(["pg_config", "--bindir"], capture_output=True, text=True, check=True)
        if _has_server_programs(out.stdout.strip()):
            return out.stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        pass
    versions = []
    for name in os.listdir("/usr/lib/postgresql") if os.path.isdir("/usr/lib/postgresql") else []:
        try:
            version = tuple(int(part) for part in name.split("."))  # "15", "9.6"
        except ValueError:
            continue
        if _has_server_programs(os.path.join("/usr/lib/postgresql", name, "bin")):
            versions.append((version, os.path.join("/usr/lib/postgresql", name, "bin")))
    if versions:
        return max(versions)[1]
    initdb = shutil.which("initdb")  # a link (/usr/local/bin/initdb) stands for where it points
    if initdb and _has_server_programs(os.path.dirname(os.path.realpath(initdb))):
        return os.path.dirname(os.path.realpath(initdb))
    return None


def _temp_base():
    """TMPDIR's folder when the server user can enter it (every folder above
    searchable by others, as /tmp is), else /tmp."""
    base = tempfile.gettempdir()
    if os.geteuid() != 0:
        return base
    path = base
    while True:
        try:
            if not os.stat(path).st_mode & stat.S_IXOTH:
                return "/tmp"
        except OSError:
            return "/tmp"
        if path == os.path.dirname(path):
            return base
        path = os.path.dirname(path)


def _free_port():
    """A port of 127.0.0.1 that was free a moment ago (bind port 0)."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _alive(pid):
    """Running, not a zombie (the postmaster's adopter may never reap it)."""
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().rsplit(")", 1)[1].split()[0] not in ("Z", "X")
    except (OSError, IndexError):
        return False


def _tail(text, limit=2000):
    return text if len(text) <= limit else "..." + text[-limit:]


class PostgresServer:
    """bindir: where initdb and pg_ctl are; None finds them (find_bindir)."""

    def __init__(self, bindir=None):
        self.bindir = bindir
        self.port = 0
        self.root = self.data_dir = self.socket_dir = self.log_path = None
        self._watchdog = None  # the write end of the watchdog's pipe
        self._owner = None  # the pid that started the server
        self._counter = 0

    @property
    def running(self):
        return self.port != 0

    def __enter__(self):
        return self.start()

    def __exit__(self, *exc):
        self.stop()

    def _prefix(self):
        """What runs a server program as SERVER_USER: nothing unless root."""
        if os.geteuid() != 0:
            return []
        return ["setpriv", f"--reuid={SERVER_USER}", f"--regid={SERVER_USER}", "--init-groups", "--"]

    def _run(self, args, as_server_user=False):
        """Runs args in "/" (a folder the server user can enter), output
        collected: the CompletedProcess."""
        args = (self._prefix() if as_server_user else []) + [str(a) for a in args]
        return subprocess.run(args, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
                              stderr=subprocess.STDOUT, text=True, cwd="/")

    def start(self):
        """Creates the cluster, starts the server and creates the database
        "tally"; returns self. Raises PostgresError, leaving nothing behind."""
        if self.running:
            return self
        try:
            self._start()
        except BaseException:
            self._clean_up()
            raise
        self._owner = os.getpid()
        atexit.register(self.stop)
        return self

    def _start(self):
        self.bindir = self.bindir or find_bindir()
        if not self.bindir or not _has_server_programs(self.bindir):
            where = self.bindir or "pg_config --bindir, /usr/lib/postgresql/*/bin or PATH"
            raise PostgresError(f"PostgreSQL is not installed: no initdb and pg_ctl in {where}"
                                " (Debian: apt-get install postgresql)")
        initdb, pg_ctl = (os.path.join(self.bindir, p) for p in ("initdb", "pg_ctl"))
        user = None
        if os.geteuid() == 0:
            try:
                user = pwd.getpwnam(SERVER_USER)
            except KeyError:
                raise PostgresError(f'running as root, and there is no "{SERVER_USER}" user to run '
                                    "PostgreSQL as (Debian's postgresql-common creates it)") from None

        self.root = tempfile.mkdtemp(prefix="tally-pg-", dir=_temp_base())
        self.data_dir = os.path.join(self.root, "data")
        self.socket_dir = os.path.join(self.root, "socket")
        self.log_path = os.path.join(self.root, "server.log")
        for d in (self.data_dir, self.socket_dir):
            os.mkdir(d, 0o700)
        if user:
            for d in (self.root, self.data_dir, self.socket_dir):
                os.chown(d, user.pw_uid, user.pw_gid)

        # The watchdog: a shell its parent sh leaves behind (ctest kills a
        # timed-out test's descendants), blocked reading a pipe whose write
        # end only this process holds. EOF stops the server and removes the
        # folder; both no-ops after a stop(). (An & list's stdin is
        # /dev/null, hence the pipe on 3.)
        read_end, self._watchdog = os.pipe()
        stop_now = shlex.join(self._prefix() + [pg_ctl, "-D", self.data_dir, "-m", "immediate", "stop"])
        script = (f"exec 3<&0; (read -r _ <&3; {stop_now}; rm -rf {shlex.quote(self.root)})"
                  " </dev/null >/dev/null 2>&1 &")
        subprocess.run(["/bin/sh", "-c", script], stdin=read_end, stdout=subprocess.DEVNULL,
                       stderr=subprocess.DEVNULL, cwd="/", check=True)
        os.close(read_end)

        # --no-sync: nothing here needs to survive a power cut.
        init = self._run([initdb, "-D", self.data_dir, "-U", "tally", "--auth=trust", "-E", "UTF8",
                          "--locale=C", "--no-sync"], as_server_user=True)
        if init.returncode != 0:
            raise PostgresError("initdb failed:\n" + _tail(init.stdout))

        # Another process may take the free port first: a few tries.
        for attempt in range(1, 6):
            self.port = _free_port()
            options = (f"-p {self.port} -k {shlex.quote(self.socket_dir)} -c listen_addresses=127.0.0.1"
                       " -c fsync=off -c max_connections=200")
            if os.path.exists(self.log_path):
                os.remove(self.log_path)  # so the log read below is this try's
            started = self._run([pg_ctl, "-D", self.data_dir, "-o", options, "-w", "-t", "60",
                                 "-l", self.log_path, "start"], as_server_user=True)
            if started.returncode == 0:
                break
            log = open(self.log_path).read() if os.path.exists(self.log_path) else ""
            if "could not bind" not in log or attempt == 5:
                self.port = 0
                raise PostgresError(f"pg_ctl start failed:\n{_tail(started.stdout)}\n"
                                    f"server log {self.log_path}:\n{_tail(log)}")
        self.create_database("tally")

    def pause(self):
        """Stops the server (pg_ctl stop -m fast) and keeps its data, port and
        folder, so that resume() brings the same databases back: an outage,
        for tests of what clients do meanwhile."""
        if not self.running:
            raise PostgresError("pause: the PostgreSQL server is not running")
        stopped = self._run([os.path.join(self.bindir, "pg_ctl"), "-D", self.data_dir, "-m", "fast", "-w",
                             "-t", "60", "stop"], as_server_user=True)
        if stopped.returncode != 0:
            raise PostgresError(f"pg_ctl stop failed:\n{_tail(stopped.stdout)}")

    def resume(self):
        """Starts a paused server again on its port."""
        options = (f"-p {self.port} -k {shlex.quote(self.socket_dir)} -c listen_addresses=127.0.0.1"
                   " -c fsync=off -c max_connections=200")
        started = self._run([os.path.join(self.bindir, "pg_ctl"), "-D", self.data_dir, "-o", options, "-w",
                             "-t", "60", "-l", self.log_path, "start"], as_server_user=True)
        if started.returncode != 0:
            raise PostgresError(f"pg_ctl start failed:\n{_tail(started.stdout)}")

    def stop(self):
        """pg_ctl stop -m fast, waits until the postmaster has exited, and
        removes the folder (log included). Does nothing when not running, and
        in a forked child of the process that started the server."""
        if not self.running or os.getpid() != self._owner:
            return
        self._clean_up()
        atexit.unregister(self.stop)

    def _clean_up(self):
        pid = 0
        try:
            with open(os.path.join(self.data_dir or "", "postmaster.pid")) as f:
                pid = int(f.readline())
        except (OSError, ValueError):
            pass
        if pid > 0:
            self._run([os.path.join(self.bindir, "pg_ctl"), "-D", self.data_dir, "-m", "fast", "-w",
                       "-t", "60", "stop"], as_server_user=True)
            # pg_ctl is done when postmaster.pid is gone; the postmaster exits
            # a moment later. One that will not: SIGQUIT, then SIGKILL.
            deadline = time.monotonic() + 10
            while _alive(pid):
                left = deadline - time.monotonic()
                if left < 5:
                    os.kill(pid, signal.SIGKILL if left < 0 else signal.SIGQUIT)
                time.sleep(0.01)
        if self.root:
            shutil.rmtree(self.root, ignore_errors=True)
        if self._watchdog is not None:
            os.close(self._watchdog)
        self._watchdog = None
        self.root = self.data_dir = self.socket_dir = self.log_path = None
        self.port = 0
        self._owner = None

    def url(self, db="tally"):
        """postgresql://tally@127.0.0.1:PORT/DB (DB percent-encoded)."""
        return f"postgresql://tally@127.0.0.1:{self.port}/{urllib.parse.quote(db, safe='')}"

    def create_database(self, name=None):
        """CREATE DATABASE (createdb); returns its url(). None makes a new
        name (test_1, test_2, ...). Raises PostgresError when refused."""
        if not self.running:
            raise PostgresError("create_database: the PostgreSQL server is not running")
        if name is None:
            self._counter += 1
            name = f"test_{self._counter}"
        if len(name.encode()) > 63:  # the server would cut it, and url() would not name it
            raise PostgresError(f"database name longer than 63 bytes: {name}")
        out = self._run([os.path.join(self.bindir, "createdb"), "-h", "127.0.0.1", "-p", self.port,
                         "-U", "tally", "--", name])
        if out.returncode != 0:
            raise PostgresError(f"createdb {name}: {out.stdout.strip()}")
        return self.url(name)

    def psql(self, db, sql):
        """Runs sql in database db with psql: its unaligned, tuples-only
        output ("a|b" per row). Raises PostgresError on any error."""
        out = self._run([os.path.join(self.bindir, "psql"), "-X", "-q", "-A", "-t", "-v", "ON_ERROR_STOP=1",
                         "-d", self.url(db), "-c", sql])
        if out.returncode != 0:
            raise PostgresError(f"psql {db}: {sql}: {out.stdout.strip()}")
        return out.stdout


_shared = None


def require_postgres():
    """The process's shared server, started on first use and stopped at exit.
    Where it cannot start, says why on stderr and exits SKIP (77), or 1 when
    tests are strict (strict.py: CI=true, or scripts/test.sh), where PostgreSQL
    must be installed."""
    global _shared
    if _shared is None:
        try:
            _shared = PostgresServer().start()
        except PostgresError as e:
            skip_or_fail(f"PostgreSQL test server: {e}")
    return _shared
