#include "common/procman/exec_line.h"

#include <glib.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cstdlib>
#include <cstring>
#include <stdexcept>

namespace kestrel::procman {
namespace {

bool IsNameChar(char c, size_t position) {
  const bool letter = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || c == '_';
  const bool digit = c >= '0' && c <= '9';
  return letter || (position == 0 && digit);
}

/// Replaces $NAME and ${NAME} in one word (step 3 of exec_line.h).
std::string ExpandVariables(const std::string& word, const VariableLookup& lookup) {
  std::string out;
  size_t i = 0;
  while (i < word.size()) {
    const char c = word[i++];
    if (c == '\\') {
      // The deputy appends the backslash and drops the character after it.
      out += '\\';
      if (i < word.size()) ++i;
      continue;
    }
    if (c != '$') {
      out += c;
      continue;
    }
    const size_t dollar = i - 1;
    const bool braces = i < word.size() && word[i] == '{';
    if (braces) ++i;
    const size_t name_start = i;
    while (i < word.size() && IsNameChar(word[i], i - name_start)) ++i;
    const std::string name = word.substr(name_start, i - name_start);
    bool ok = !name.empty();
    if (braces) {
      // The character after the name is consumed whatever it is; it must be '}'.
      if (i < word.size()) {
        ok = ok && word[i] == '}';
        ++i;
      } else {
        ok = false;
      }
    }
    std::optional<std::string> value;
    if (ok) value = lookup(name);
    if (value) {
      out += *value;
    } else {
      out.append(word, dollar, i - dollar);
    }
  }
  return out;
}

std::vector<std::string> SplitOnBlanks(const std::string& exec) {
  std::vector<std::string> words;
  std::string word;
  for (const char c : exec) {
    if (c == ' ' || c == '\t' || c == '\n') {
      if (!word.empty()) words.push_back(word);
      word.clear();
    } else {
      word += c;
    }
  }
  if (!word.empty()) words.push_back(word);
  return words;
}

}  // namespace

ExecLine ParseExecLine(const std::string& exec, const VariableLookup& lookup) {
  ExecLine line;
  gint argc = 0;
  gchar** argv = nullptr;
  GError* error = nullptr;
  if (!g_shell_parse_argv(exec.c_str(), &argc, &argv, &error)) {
    // The deputy's fallback: blank-separated words, no settings, no expansion.
    if (error != nullptr) g_error_free(error);
    line.argv = SplitOnBlanks(exec);
    return line;
  }
  int i = 0;
  for (; i < argc && std::strchr(argv[i], '=') != nullptr; ++i) {
    const char* eq = std::strchr(argv[i], '=');
    const std::string word(argv[i]);
    const size_t at = static_cast<size_t>(eq - argv[i]);
    line.environment.emplace_back(word.substr(0, at), word.substr(at + 1));
  }
  for (; i < argc; ++i) line.argv.push_back(ExpandVariables(argv[i], lookup));
  g_strfreev(argv);
  return line;
}

std::optional<std::string> ResolveProgram(const std::string& program, const std::string& path) {
  const auto executable = [](const std::string& file) {
    struct stat st {};
    return stat(file.c_str(), &st) == 0 && S_ISREG(st.st_mode) && access(file.c_str(), X_OK) == 0;
  };
  if (program.empty()) return std::nullopt;
  if (program.find('/') != std::string::npos) {
    if (executable(program)) return program;
    return std::nullopt;
  }
  size_t start = 0;
  while (start <= path.size()) {
    size_t end = path.find(':', start);
    if (end == std::string::npos) end = path.size();
    const std::string folder = path.substr(start, end - start);
    const std::string candidate = (folder.empty() ? "." : folder) + "/" + program;
    if (executable(candidate)) return candidate;
    start = end + 1;
  }
  return std::nullopt;
}

VariableLookup EnvironmentLookup() {
  return [](const std::string& name) -> std::optional<std::string> {
    const char* value = std::getenv(name.c_str());  // NOLINT(concurrency-mt-unsafe)
    if (value == nullptr) return std::nullopt;
    return std::string(value);
  };
}

}  // namespace kestrel::procman

namespace kestrel::procman {

std::vector<EnvironmentDefault> ParseEnvironmentDefaults(const std::string& text,
                                                         const std::string& file) {
  std::vector<EnvironmentDefault> out;
  size_t start = 0;
  for (int line_number = 1; start <= text.size(); ++line_number) {
    size_t end = text.find('\n', start);
    if (end == std::string::npos) end = text.size();
    const std::string line = text.substr(start, end - start);
    start = end + 1;
    const size_t first = line.find_first_not_of(" \t\r");
    if (first == std::string::npos || line[first] == '#') continue;
    const size_t eq = line.find('=');
    bool valid = eq != std::string::npos && eq > 0 && !(line[0] >= '0' && line[0] <= '9');
    for (size_t i = 0; valid && i < eq; ++i) {
      const char c = line[i];
      valid =
          (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_';
    }
    if (!valid) {
      throw std::runtime_error(file + ":" + std::to_string(line_number) +
                               ": expected NAME=value, got '" + line + "'");
    }
    out.push_back(EnvironmentDefault{line.substr(0, eq), line.substr(eq + 1), line_number});
  }
  return out;
}

}  // namespace kestrel::procman
