#include "silpose/util/child_process.h"

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/syscall.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <fstream>
#include <iterator>
#include <optional>
#include <sstream>
#include <string_view>

namespace silpose {
namespace {

void WriteAll(int fd, std::string_view bytes) {
  while (!bytes.empty()) {
    const ssize_t written = write(fd, bytes.data(), bytes.size());
    if (written < 0 && errno == EINTR) continue;
    if (written <= 0) return;
    bytes.remove_prefix(static_cast<size_t>(written));
  }
}

// What /proc says of a process: its state letter and the CPU time it has used (clock ticks).
struct ProcessActivity {
  char state = '?';
  unsigned long long cpu_ticks = 0;
};

std::optional<ProcessActivity> ReadActivity(pid_t pid) {
  std::ifstream file("/proc/" + std::to_string(pid) + "/stat");
  const std::string text((std::istreambuf_iterator<char>(file)), std::istreambuf_iterator<char>());
  // "pid (name) state ppid ... utime stime ...": the name may hold spaces and parentheses, so the
  // fields are counted from the last ')'. utime and stime are fields 14 and 15.
  const size_t close = text.rfind(')');
  if (close == std::string::npos) return std::nullopt;
  std::istringstream fields(text.substr(close + 1));
  ProcessActivity activity;
  fields >> activity.state;
  std::string skipped;
  for (int field = 4; field <= 13; ++field) fields >> skipped;
  unsigned long long user = 0;
  unsigned long long system = 0;
  if (!(fields >> user >> system)) return std::nullopt;
  activity.cpu_ticks = user + system;
  return activity;
}

// Whether the process sleeps in futex(): /proc/PID/syscall starts with the number of the call a
// blocked process is in. Empty where the kernel does not let this process read it.
std::optional<bool> SleepsInFutex(pid_t pid) {
  std::ifstream file("/proc/" + std::to_string(pid) + "/syscall");
  long number = -1;
  if (!(file >> number)) return std::nullopt;
  return number == SYS_futex;
}

}  // namespace

ChildProcessResult RunInChildProcess(const std::function<std::string()>& work,
                                     double stall_seconds) {
  ChildProcessResult result;
  int fds[2];
  if (pipe2(fds, O_CLOEXEC) != 0) return result;
  const pid_t child = fork();
  if (child < 0) {
    close(fds[0]);
    close(fds[1]);
    return result;
  }
  if (child == 0) {
    close(fds[0]);
    int status = 0;
    try {
      WriteAll(fds[1], work());
    } catch (...) {
      status = 70;
    }
    _exit(status);
  }
  result.started = true;
  close(fds[1]);

  using Clock = std::chrono::steady_clock;
  bool seen_still = false;        // the child was seen asleep, in a wait nothing may end...
  Clock::time_point still_since;  // ...since then, without using CPU time
  unsigned long long last_ticks = 0;
  char buffer[1 << 16];
  for (;;) {
    pollfd readable{fds[0], POLLIN, 0};
    const int ready = poll(&readable, 1, 200);
    if (ready < 0 && errno != EINTR) break;
    if (ready > 0) {
      const ssize_t got = read(fds[0], buffer, sizeof(buffer));
      if (got < 0 && errno == EINTR) continue;
      if (got <= 0) break;  // the child closed its end: it has ended
      result.output.append(buffer, static_cast<size_t>(got));
      seen_still = false;
      continue;
    }
    if (ready < 0) continue;
    // Nothing to read for a while: is the child still at work?
    const std::optional<ProcessActivity> activity = ReadActivity(child);
    if (!activity) continue;
    bool waits_forever = activity->state == 'S';
    if (waits_forever) {
      const std::optional<bool> futex = SleepsInFutex(child);
      if (futex) waits_forever = *futex;
    }
    const Clock::time_point now = Clock::now();
    if (!waits_forever || !seen_still || activity->cpu_ticks != last_ticks) {
      last_ticks = activity->cpu_ticks;
      seen_still = waits_forever;
      still_since = now;
      continue;
    }
    if (std::chrono::duration<double>(now - still_since).count() >= stall_seconds) {
      result.stuck = true;
      kill(child, SIGKILL);
      break;
    }
  }
  close(fds[0]);
  int status = 0;
  pid_t waited;
  do {
    waited = waitpid(child, &status, 0);
  } while (waited < 0 && errno == EINTR);
  if (!result.stuck) result.wait_status = waited == child ? status : 0;
  return result;
}

}  // namespace silpose
