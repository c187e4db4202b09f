#pragma once
/// @file
/// A sheet command's `exec` string turned into what is executed, exactly as a libbot2
/// bot-procman deputy does it (docs/protocols.md §5.3): no shell is involved.
///  1. The string is split into words by glib's g_shell_parse_argv (the deputy's own splitter):
///     single and double quotes and backslashes as in sh, `#` comments, no expansion at all.
///     Where it fails (an empty string, an unmatched quote), the deputy splits on spaces, tabs
///     and newlines instead; so does this.
///  2. Leading words that contain `=` are NAME=value settings of the child's environment (taken
///     as written, never expanded).
///  3. In every other word, `$NAME` and `${NAME}` are replaced by the variable's value
///     (`lookup`); an unset variable or a malformed `${` is left as written. Nothing else is
///     expanded: no `${NAME:-default}`, `~`, globs or `$(...)`. A name is letters and `_`, with
///     a digit allowed only as its first character (the deputy's rule). A backslash that
///     survived step 1 (inside single quotes) swallows the character after it, as the deputy's
///     expansion does.
/// The first remaining word is the program, found on PATH (execvp).

#include <functional>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace kestrel::procman {

struct ExecLine {
  std::vector<std::pair<std::string, std::string>> environment;  ///< leading NAME=value words
  std::vector<std::string> argv;                                 ///< program and its arguments
};

/// The value of a variable, or nullopt when unset.
using VariableLookup = std::function<std::optional<std::string>(const std::string& name)>;

/// Splits and expands `exec` as above. `argv` may be empty (nothing to run).
[[nodiscard]] ExecLine ParseExecLine(const std::string& exec, const VariableLookup& lookup);

/// The process environment as a VariableLookup (getenv).
[[nodiscard]] VariableLookup EnvironmentLookup();

/// The file execvp would run for `program`: itself if it holds a '/', else the first executable
/// PATH entry (`path`, colon-separated; an empty entry is the working folder). nullopt if none.
[[nodiscard]] std::optional<std::string> ResolveProgram(const std::string& program,
                                                        const std::string& path);

}  // namespace kestrel::procman

namespace kestrel::procman {

/// One NAME=value line of an environment defaults file (scripts/sheets/kestrel.env).
struct EnvironmentDefault {
  std::string name;
  std::string value;
  int line{0};
};
/// Parses `NAME=value` lines (NAME letters, digits and `_`, not starting with a digit; the value
/// is the rest of the line, taken literally); blank lines and lines starting with `#` are
/// skipped. @throws std::runtime_error "FILE:LINE: reason" on any other line.
[[nodiscard]] std::vector<EnvironmentDefault> ParseEnvironmentDefaults(const std::string& text,
                                                                       const std::string& file);

}  // namespace kestrel::procman
