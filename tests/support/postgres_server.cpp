#include "postgres_server.hpp"

#include <arpa/inet.h>
#include <fcntl.h>
#include <libpq-fe.h>
#include <netinet/in.h>
#include <pwd.h>
#include <signal.h>
#include <spawn.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <cctype>
#include <cerrno>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <stdexcept>
#include <thread>
#include <vector>

#include "strict.hpp"
#include "proc_file.hpp"
#include "read_file.hpp"

extern char** environ;

namespace tally::testing {
namespace {

namespace fs = std::filesystem;

// The user initdb and postgres run as under root (they refuse root itself).
constexpr const char* kServerUser = "postgres";

bool isRoot() { return ::geteuid() == 0; }

// What runs a server program as kServerUser: nothing unless root. setpriv
// (util-linux, like runuser) switches user without a PAM session.
std::vector<std::string> userPrefix() {
  if (!isRoot()) return {};
  return {"setpriv", "--reuid=postgres", "--regid=postgres", "--init-groups", "--"};
}

struct Output {
  int status = -1;   // the exit status; -1: could not run, or killed
  std::string text;  // stdout and stderr together
};

// Runs argv (PATH searched) in "/" with stdin from /dev/null, and collects
// what it prints. "/": a folder the server user can enter whatever ours is.
Output run(std::vector<std::string> argv, bool asServerUser = false) {
  if (asServerUser) {
    std::vector<std::string> full = userPrefix();
    full.insert(full.end(), argv.begin(), argv.end());
    argv = std::move(full);
  }
  Output out;
  int pipeFds[2];
  if (::pipe2(pipeFds, O_CLOEXEC) != 0) {
    out.text = std::string("pipe: ") + std::strerror(errno);
    return out;
  }
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 0, "/dev/null", O_RDONLY, 0);
  posix_spawn_file_actions_adddup2(&actions, pipeFds[1], 1);
  posix_spawn_file_actions_adddup2(&actions, pipeFds[1], 2);
  posix_spawn_file_actions_addchdir_np(&actions, "/");
  std::vector<char*> args;
  for (auto& a : argv) args.push_back(a.data());
  args.push_back(nullptr);
  pid_t pid = 0;
  int rc = ::posix_spawnp(&pid, args[0], &actions, nullptr, args.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  ::close(pipeFds[1]);
  if (rc != 0) {
    ::close(pipeFds[0]);
    out.text = argv[0] + ": " + std::strerror(rc);
    return out;
  }
  char buf[4096];
  for (ssize_t n; (n = ::read(pipeFds[0], buf, sizeof buf)) != 0;) {
    if (n < 0 && errno != EINTR) break;
    if (n > 0) out.text.append(buf, size_t(n));
  }
  ::close(pipeFds[0]);
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) continue;
  if (WIFEXITED(status)) out.status = WEXITSTATUS(status);
  return out;
}

std::string shellQuote(const std::string& s) {
  std::string q = "'";
  for (char c : s) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}

std::string joinQuoted(const std::vector<std::string>& words) {
  std::string line;
  for (auto& w : words) line += (line.empty() ? "" : " ") + shellQuote(w);
  return line;
}

bool hasServerPrograms(const fs::path& dir) {
  return ::access((dir / "initdb").c_str(), X_OK) == 0 && ::access((dir / "pg_ctl").c_str(), X_OK) == 0;
}

// pg_config --bindir (libpq-dev's names the server of its version), else the
// highest /usr/lib/postgresql/VERSION/bin (Debian), else initdb on PATH.
fs::path findBinDir() {
  Output config = run({"pg_config", "--bindir"});
  while (!config.text.empty() && std::isspace(static_cast<unsigned char>(config.text.back())))
    config.text.pop_back();
  if (config.status == 0 && hasServerPrograms(config.text)) return config.text;

  fs::path best;
  double bestVersion = -1;
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator("/usr/lib/postgresql", ec)) {
    const std::string name = entry.path().filename();
    char* end = nullptr;
    double version = std::strtod(name.c_str(), &end);  // "15", "9.6"
    if (end == name.c_str() || *end != '\0' || !hasServerPrograms(entry.path() / "bin")) continue;
    if (version > bestVersion) bestVersion = version, best = entry.path() / "bin";
  }
  if (!best.empty()) return best;

  const char* path = std::getenv("PATH");
  for (std::string_view rest = path ? path : ""; !rest.empty();) {
    size_t colon = rest.find(':');
    fs::path dir(rest.substr(0, colon));
    rest = colon == rest.npos ? "" : rest.substr(colon + 1);
    // A link (/usr/local/bin/initdb) stands for the folder it points into.
    if (!dir.empty() && ::access((dir / "initdb").c_str(), X_OK) == 0) {
      fs::path real = fs::canonical(dir / "initdb", ec).parent_path();
      if (!ec && hasServerPrograms(real)) return real;
    }
  }
  return {};
}

// The temporary folder's parent: TMPDIR's when the server user can enter it
// (every folder above it searchable by others, as /tmp is), else /tmp.
fs::path tempBase() {
  std::error_code ec;
  fs::path base = fs::temp_directory_path(ec);
  if (ec) return "/tmp";
  if (!isRoot()) return base;
  for (fs::path p = base;; p = p.parent_path()) {
    struct stat st {};
    if (::stat(p.c_str(), &st) != 0 || (st.st_mode & S_IXOTH) == 0) return "/tmp";
    if (p == p.root_path()) return base;
  }
}

// A port of 127.0.0.1 that was free a moment ago (bind port 0, read it back).
// Another process may take it first: start() then tries another.
int freePort() {
  int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd < 0) return 0;
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  socklen_t len = sizeof addr;
  int port = 0;
  if (::bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) == 0 &&
      ::getsockname(fd, reinterpret_cast<sockaddr*>(&addr), &len) == 0)
    port = ntohs(addr.sin_port);
  ::close(fd);
  return port;
}

// Running, not a zombie: the postmaster is not our child, and whoever adopts
// it (a container's PID 1) may never reap it.
bool processAlive(pid_t pid) {
  std::string stat = tally::test::readProcFile("/proc/" + std::to_string(pid) + "/stat");
  size_t paren = stat.rfind(')');
  return paren != std::string::npos && paren + 2 < stat.size() && stat[paren + 2] != 'Z' &&
         stat[paren + 2] != 'X';
}

pid_t postmasterPid(const fs::path& dataDir) {
  return static_cast<pid_t>(std::atol(tally::test::readFile(dataDir / "postmaster.pid").c_str()));
}

std::string tail(const std::string& text, size_t max = 2000) {
  return text.size() <= max ? text : "..." + text.substr(text.size() - max);
}

std::string percentEncode(std::string_view s) {
  static const char* hex = "0123456789ABCDEF";
  std::string out;
  for (unsigned char c : s) {
    bool plain = std::isalnum(c) || c == '_' || c == '-' || c == '.' || c == '~';
    out += plain ? std::string(1, char(c)) : std::string{'%', hex[c >> 4], hex[c & 15]};
  }
  return out;
}

}  // namespace

PostgresServer::PostgresServer(std::filesystem::path binDir) : binDir_(std::move(binDir)) {}

PostgresServer::~PostgresServer() { stop(); }

std::optional<std::string> PostgresServer::start() {
  if (running()) return std::nullopt;
  if (auto error = tryStart()) {
    cleanUp();  // nothing left behind
    return error;
  }
  owner_ = ::getpid();
  return std::nullopt;
}

std::optional<std::string> PostgresServer::tryStart() {
  if (binDir_.empty()) binDir_ = findBinDir();
  if (binDir_.empty() || !hasServerPrograms(binDir_))
    return "PostgreSQL is not installed: no initdb and pg_ctl in " +
           (binDir_.empty() ? std::string("pg_config --bindir, /usr/lib/postgresql/*/bin or PATH")
                            : binDir_.string()) +
           " (Debian: apt-get install postgresql)";
  const std::string initdb = binDir_ / "initdb", pgCtl = binDir_ / "pg_ctl";

  const passwd* user = isRoot() ? ::getpwnam(kServerUser) : nullptr;
  if (isRoot() && user == nullptr)
    return std::string("running as root, and there is no \"") + kServerUser +
           "\" user to run PostgreSQL as (Debian's postgresql-common creates it)";

  std::string pattern = (tempBase() / "tally-pg-XXXXXX").string();
  if (::mkdtemp(pattern.data()) == nullptr) return "mkdtemp " + pattern + ": " + std::strerror(errno);
  root_ = pattern;
  data_ = root_ / "data";
  socketDir_ = root_ / "socket";
  log_ = root_ / "server.log";
  for (const auto& dir : {data_, socketDir_})
    if (::mkdir(dir.c_str(), 0700) != 0) return "mkdir " + dir.string() + ": " + std::strerror(errno);
  if (user != nullptr)
    for (const auto& dir : {root_, data_, socketDir_})
      if (::chown(dir.c_str(), user->pw_uid, user->pw_gid) != 0)
        return "chown " + dir.string() + ": " + std::strerror(errno);

  // The watchdog: a shell that its parent sh leaves behind (so ctest, which
  // kills a timed-out test's descendants, misses it), blocked reading the
  // pipe whose write end only this process holds. EOF (this process gone,
  // or cleanUp() done) stops the server and removes the folder; both no-ops
  // after a stop().
  int pipeFds[2];
  if (::pipe2(pipeFds, O_CLOEXEC) != 0) return std::string("pipe: ") + std::strerror(errno);
  std::vector<std::string> stopNow = userPrefix();
  stopNow.insert(stopNow.end(), {pgCtl, "-D", data_.string(), "-m", "immediate", "stop"});
  // (An & list's stdin is /dev/null, hence the pipe on 3.)
  std::string script = "exec 3<&0; (read -r _ <&3; " + joinQuoted(stopNow) + "; rm -rf " + shellQuote(root_) +
                       ") </dev/null >/dev/null 2>&1 &";
  {
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_adddup2(&actions, pipeFds[0], 0);
    posix_spawn_file_actions_addopen(&actions, 1, "/dev/null", O_WRONLY, 0);
    posix_spawn_file_actions_addopen(&actions, 2, "/dev/null", O_WRONLY, 0);
    posix_spawn_file_actions_addchdir_np(&actions, "/");
    const char* argv[] = {"/bin/sh", "-c", script.c_str(), nullptr};
    pid_t pid = 0;
    int rc = ::posix_spawn(&pid, "/bin/sh", &actions, nullptr, const_cast<char**>(argv), environ);
    posix_spawn_file_actions_destroy(&actions);
    ::close(pipeFds[0]);
    if (rc != 0) {
      ::close(pipeFds[1]);
      return std::string("watchdog: ") + std::strerror(rc);
    }
    watchdogFd_ = pipeFds[1];
    int status = 0;
    while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) continue;
  }

  // --no-sync: nothing here needs to survive a power cut.
  Output init = run(
      {initdb, "-D", data_, "-U", "tally", "--auth=trust", "-E", "UTF8", "--locale=C", "--no-sync"}, true);
  if (init.status != 0) return "initdb failed:\n" + tail(init.text);

  // Another process may take the free port before the server binds it: a
  // few tries, each on a port just found free.
  std::error_code ec;
  for (int attempt = 1;; ++attempt) {
    port_ = freePort();
    if (port_ == 0) return std::string("no free port on 127.0.0.1: ") + std::strerror(errno);
    std::string options = "-p " + std::to_string(port_) + " -k " + shellQuote(socketDir_) +
                          " -c listen_addresses=127.0.0.1 -c fsync=off -c max_connections=200";
    fs::remove(log_, ec);  // so the log read below is this try's
    Output started = run({pgCtl, "-D", data_, "-o", options, "-w", "-t", "60", "-l", log_, "start"}, true);
    if (started.status == 0) break;
    std::string log = tally::test::readFile(log_);
    bool portTaken = log.find("could not bind") != std::string::npos;
    if (!portTaken || attempt == 5) {
      port_ = 0;
      return "pg_ctl start failed:\n" + tail(started.text) + "\nserver log " + log_.string() + ":\n" +
             tail(log);
    }
  }

  std::string conninfo = "host=127.0.0.1 port=" + std::to_string(port_) + " user=tally dbname=postgres";
  admin_ = PQconnectdb(conninfo.c_str());
  if (PQstatus(admin_) != CONNECTION_OK) return "connecting to " + conninfo + ": " + PQerrorMessage(admin_);
  try {
    createDatabase("tally");
  } catch (const std::exception& e) {
    return e.what();
  }
  return std::nullopt;
}

void PostgresServer::stop() {
  if (!running() || ::getpid() != owner_) return;
  cleanUp();
}

void PostgresServer::cleanUp() {
  if (admin_ != nullptr) PQfinish(admin_), admin_ = nullptr;
  pid_t pid = data_.empty() ? 0 : postmasterPid(data_);
  if (pid > 0) {
    run({binDir_ / "pg_ctl", "-D", data_, "-m", "fast", "-w", "-t", "60", "stop"}, true);
    // pg_ctl is done when postmaster.pid is gone; the postmaster exits a
    // moment later. One that will not: SIGQUIT (immediate), then SIGKILL.
    auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
    while (processAlive(pid)) {
      auto now = std::chrono::steady_clock::now();
      if (now > deadline - std::chrono::seconds(5)) ::kill(pid, now > deadline ? SIGKILL : SIGQUIT);
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
  }
  std::error_code ec;
  if (!root_.empty()) fs::remove_all(root_, ec);
  if (watchdogFd_ >= 0) ::close(watchdogFd_), watchdogFd_ = -1;
  root_.clear(), data_.clear(), socketDir_.clear(), log_.clear();
  port_ = 0;
  owner_ = 0;
}

std::string PostgresServer::url(std::string_view database) const {
  return "postgresql://tally@127.0.0.1:" + std::to_string(port_) + "/" + percentEncode(database);
}

std::string PostgresServer::createDatabase(std::string_view name) {
  std::lock_guard lock(mutex_);
  if (admin_ == nullptr) throw std::runtime_error("createDatabase: the PostgreSQL server is not running");
  std::string database = name.empty() ? "test_" + std::to_string(++counter_) : std::string(name);
  // The server would cut a longer name to 63 bytes and url() would not name it.
  if (database.size() > 63) throw std::runtime_error("database name longer than 63 bytes: " + database);
  if (PQstatus(admin_) != CONNECTION_OK) PQreset(admin_);
  char* quoted = PQescapeIdentifier(admin_, database.data(), database.size());
  if (quoted == nullptr) throw std::runtime_error(std::string("createDatabase: ") + PQerrorMessage(admin_));
  // FILE_COPY (PostgreSQL 15 and later default to WAL_LOG): copies
  // template1's files and checkpoints, which with fsync off measured about
  // a quarter faster here for an empty template.
  std::string sql = std::string("CREATE DATABASE ") + quoted +
                    (PQserverVersion(admin_) >= 150000 ? " STRATEGY = FILE_COPY" : "");
  PQfreemem(quoted);
  PGresult* result = PQexec(admin_, sql.c_str());
  bool ok = PQresultStatus(result) == PGRES_COMMAND_OK;
  std::string error = ok ? "" : PQresultErrorMessage(result);
  PQclear(result);
  if (!ok) throw std::runtime_error(sql + ": " + error);
  return url(database);
}

namespace {

// Skips the current test, or fails it where tests are strict (strict.hpp:
// CI=true, or scripts/test.sh), where PostgreSQL is required.
void skipOrFail(const std::string& error) {
  [&] { TALLY_SKIP_UNLESS_STRICT("PostgreSQL test server: " << error); }();
}

}  // namespace

PostgresServer* requirePostgres() {
  static PostgresServer server;
  static const std::optional<std::string> error = server.start();  // once, thread-safe
  if (!error) return &server;
  skipOrFail(*error);
  return nullptr;
}

bool requireStarted(PostgresServer& server) {
  std::optional<std::string> error = server.start();
  if (error) skipOrFail(*error);
  return !error;
}

}  // namespace tally::testing
