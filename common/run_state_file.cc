#include "common/run_state_file.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <sstream>
#include <vector>

namespace kestrel {

namespace {

constexpr const char* kMagic = "kestrel-state";
constexpr const char* kVersion = "1";

bool Token(const std::string& s) {
  if (s.empty()) return false;
  for (char c : s) {
    if (std::isspace(static_cast<unsigned char>(c)) || c == '\0') return false;
  }
  return true;
}

std::string SystemError(const std::string& what, const std::string& path) {
  return what + " " + path + ": " + std::strerror(errno);
}

}  // namespace

const std::string* RunStateFile::Find(const std::string& key) const {
  const auto it = values.find(key);
  return it == values.end() ? nullptr : &it->second;
}

bool RunStateFile::GetDouble(const std::string& key, double* out) const {
  const std::string* text = Find(key);
  if (text == nullptr) return false;
  char* end = nullptr;
  const double v = std::strtod(text->c_str(), &end);
  if (end == text->c_str() || *end != '\0' || !std::isfinite(v)) return false;
  *out = v;
  return true;
}

bool WriteRunStateFile(const std::string& path, const RunStateFile& state, std::string* error) {
  std::string local_error;
  if (error == nullptr) error = &local_error;
  if (!Token(state.kind) || !Token(state.run_id)) {
    *error = "state file " + path + ": kind and run id must be non-empty, without spaces";
    return false;
  }
  std::ostringstream text;
  text << kMagic << ' ' << state.kind << ' ' << kVersion << '\n';
  text << "run_id " << state.run_id << '\n';
  for (const auto& [key, value] : state.values) {
    if (!Token(key) || !Token(value) || key == "run_id") {
      *error = "state file " + path + ": bad entry '" + key + "' = '" + value + "'";
      return false;
    }
    text << key << ' ' << value << '\n';
  }
  const std::string bytes = text.str();
  const std::string tmp = path + ".tmp";
  int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0 && errno == ENOENT) {  // the run folder does not exist yet: make it (one level)
    const size_t slash = path.find_last_of('/');
    if (slash != std::string::npos && slash > 0) {
      ::mkdir(path.substr(0, slash).c_str(), 0755);
      fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
    }
  }
  if (fd < 0) {
    *error = SystemError("cannot create", tmp);
    return false;
  }
  size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t n = ::write(fd, bytes.data() + done, bytes.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      *error = SystemError("cannot write", tmp);
      ::close(fd);
      return false;
    }
    done += static_cast<size_t>(n);
  }
  if (::close(fd) != 0) {
    *error = SystemError("cannot close", tmp);
    return false;
  }
  if (::rename(tmp.c_str(), path.c_str()) != 0) {
    *error = SystemError("cannot rename " + tmp + " to", path);
    return false;
  }
  return true;
}

RunStateRead ReadRunStateFile(const std::string& path, const std::string& kind,
                              const std::string& run_id, RunStateFile* out, std::string* error) {
  std::string local_error;
  if (error == nullptr) error = &local_error;
  std::ifstream in(path);
  if (!in) {
    if (::access(path.c_str(), F_OK) != 0) {
      *error = "no state file " + path;
      return RunStateRead::kAbsent;
    }
    *error = SystemError("cannot read the state file", path);
    return RunStateRead::kCorrupt;
  }
  RunStateFile file;
  std::string line;
  int number = 0;
  auto corrupt = [&](const std::string& why) {
    *error = "corrupt state file " + path + " (line " + std::to_string(number) + "): " + why;
    return RunStateRead::kCorrupt;
  };
  while (std::getline(in, line)) {
    ++number;
    std::istringstream words(line);
    std::vector<std::string> w;
    for (std::string word; words >> word;) w.push_back(word);
    if (number == 1) {
      if (w.size() != 3 || w[0] != kMagic) return corrupt("not a kestrel state file");
      if (w[1] != kind) return corrupt("a " + w[1] + " state file, expected " + kind);
      if (w[2] != kVersion) return corrupt("version " + w[2] + ", expected " + kVersion);
      file.kind = w[1];
      continue;
    }
    if (w.size() != 2) return corrupt("expected 'key value', found '" + line + "'");
    if (number == 2) {
      if (w[0] != "run_id") return corrupt("the second line must be the run id");
      file.run_id = w[1];
      continue;
    }
    if (w[0] == "run_id" || !file.values.emplace(w[0], w[1]).second) {
      return corrupt("'" + w[0] + "' given twice");
    }
  }
  if (number < 2) return corrupt("truncated (no run id)");
  *out = file;
  if (file.run_id != run_id) {
    *error = "state file " + path + " belongs to run " + file.run_id + ", not to this run (" +
             run_id + ")";
    return RunStateRead::kOtherRun;
  }
  return RunStateRead::kOk;
}

}  // namespace kestrel
