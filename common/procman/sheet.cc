#include "common/procman/sheet.h"

#include <cctype>
#include <fstream>
#include <set>
#include <sstream>
#include <stdexcept>

namespace kestrel::procman {

namespace {

struct Token {
  enum class Kind { kWord, kString, kNumber, kSymbol, kEnd };
  Kind kind{Kind::kEnd};
  std::string text;
  int line{0};
};

class Lexer {
 public:
  Lexer(const std::string& text, const std::string& file) : text_(text), file_(file) {}

  std::vector<Token> Tokens() {
    std::vector<Token> out;
    while (true) {
      SkipSpaceAndComments();
      Token t;
      t.line = line_;
      if (pos_ >= text_.size()) {
        out.push_back(t);
        return out;
      }
      const char c = text_[pos_];
      if (c == '"') {
        t.kind = Token::Kind::kString;
        ++pos_;
        while (pos_ < text_.size() && text_[pos_] != '"') {
          if (text_[pos_] == '\n') Fail(t.line, "unterminated string");
          if (text_[pos_] == '\\' && pos_ + 1 < text_.size()) ++pos_;
          t.text += text_[pos_++];
        }
        if (pos_ >= text_.size()) Fail(t.line, "unterminated string");
        ++pos_;
      } else if (std::isdigit(static_cast<unsigned char>(c)) || c == '-') {
        t.kind = Token::Kind::kNumber;
        while (pos_ < text_.size() && (std::isdigit(static_cast<unsigned char>(text_[pos_])) ||
                                       text_[pos_] == '.' || text_[pos_] == '-')) {
          t.text += text_[pos_++];
        }
      } else if (std::isalpha(static_cast<unsigned char>(c)) || c == '_') {
        t.kind = Token::Kind::kWord;
        while (pos_ < text_.size() &&
               (std::isalnum(static_cast<unsigned char>(text_[pos_])) || text_[pos_] == '_')) {
          t.text += text_[pos_++];
        }
      } else if (c == '{' || c == '}' || c == '=' || c == ';') {
        t.kind = Token::Kind::kSymbol;
        t.text = std::string(1, c);
        ++pos_;
      } else {
        Fail(line_, std::string("unexpected character '") + c + "'");
      }
      out.push_back(t);
    }
  }

  [[noreturn]] void Fail(int line, const std::string& why) const {
    throw std::runtime_error(file_ + ":" + std::to_string(line) + ": " + why);
  }

 private:
  void SkipSpaceAndComments() {
    while (pos_ < text_.size()) {
      const char c = text_[pos_];
      if (c == '\n') {
        ++line_;
        ++pos_;
      } else if (std::isspace(static_cast<unsigned char>(c))) {
        ++pos_;
      } else if (c == '#') {
        while (pos_ < text_.size() && text_[pos_] != '\n') ++pos_;
      } else {
        return;
      }
    }
  }

  const std::string& text_;
  const std::string& file_;
  size_t pos_{0};
  int line_{1};
};

class Parser {
 public:
  Parser(std::vector<Token> tokens, const std::string& file) : t_(std::move(tokens)), file_(file) {}

  Sheet Parse() {
    Sheet sheet;
    sheet.file = file_;
    ParseElements(&sheet, "", /*top_level=*/true);
    Check(sheet);
    return sheet;
  }

 private:
  [[noreturn]] void Fail(const Token& at, const std::string& why) const {
    throw std::runtime_error(file_ + ":" + std::to_string(at.line) + ": " + why);
  }
  const Token& Peek() const { return t_[i_]; }
  Token Next() {
    Token t = t_[i_];
    if (t.kind != Token::Kind::kEnd) ++i_;
    return t;
  }
  Token Expect(Token::Kind kind, const std::string& what) {
    Token t = Next();
    if (t.kind != kind)
      Fail(t, "expected " + what + (t.text.empty() ? "" : ", found '" + t.text + "'"));
    return t;
  }
  void ExpectSymbol(const std::string& s) {
    const Token t = Next();
    if (t.kind != Token::Kind::kSymbol || t.text != s) {
      Fail(t, "expected '" + s + "'" +
                  (t.text.empty() ? " before the end" : ", found '" + t.text + "'"));
    }
  }

  // Groups nest by recursion; a sheet nesting deeper than this is refused rather than left to
  // exhaust the stack.
  static constexpr int kMaxGroupDepth = 32;

  void ParseElements(Sheet* sheet, const std::string& group, bool top_level, int depth = 0) {
    while (true) {
      const Token& t = Peek();
      if (t.kind == Token::Kind::kEnd) {
        if (!top_level) Fail(t, "missing '}' to close group \"" + group + "\"");
        return;
      }
      if (t.kind == Token::Kind::kSymbol && t.text == "}") {
        if (top_level) Fail(t, "unexpected '}'");
        return;
      }
      const Token word = Expect(Token::Kind::kWord, "cmd, group or script");
      if (word.text == "cmd") {
        sheet->commands.push_back(ParseCommand(group, word.line));
      } else if (word.text == "group") {
        const Token name = Expect(Token::Kind::kString, "a quoted group name");
        if (name.text.find('/') != std::string::npos)
          Fail(name, "'/' is not allowed in group names");
        if (depth >= kMaxGroupDepth) {
          Fail(name, "groups nested deeper than " + std::to_string(kMaxGroupDepth));
        }
        ExpectSymbol("{");
        ParseElements(sheet, group.empty() ? name.text : group + "/" + name.text, false, depth + 1);
        ExpectSymbol("}");
      } else if (word.text == "script") {
        if (!top_level) Fail(word, "scripts must be at the top level");
        sheet->scripts.push_back(ParseScript());
      } else {
        Fail(word, "expected cmd, group or script, found '" + word.text + "'");
      }
    }
  }

  Command ParseCommand(const std::string& group, int line) {
    Command cmd;
    cmd.line = line;
    cmd.group = group;
    cmd.id = Expect(Token::Kind::kString, "a quoted command id").text;
    ExpectSymbol("{");
    std::set<std::string> seen;
    while (!(Peek().kind == Token::Kind::kSymbol && Peek().text == "}")) {
      const Token key = Expect(Token::Kind::kWord, "an attribute name");
      if (!seen.insert(key.text).second) Fail(key, "attribute '" + key.text + "' given twice");
      ExpectSymbol("=");
      const Token value = Next();
      if (value.kind != Token::Kind::kString && value.kind != Token::Kind::kNumber) {
        Fail(value, "expected a quoted string or an integer for '" + key.text + "'");
      }
      ExpectSymbol(";");
      if (key.text == "exec") {
        cmd.exec = value.text;
      } else if (key.text == "host") {
        cmd.host = value.text;
      } else if (key.text == "auto_respawn") {
        if (value.text != "true" && value.text != "false") {
          Fail(value, "auto_respawn must be \"true\" or \"false\", found \"" + value.text + "\"");
        }
        cmd.auto_respawn = value.text == "true";
      } else if (key.text == "stop_signal") {
        cmd.stop_signal = ParseInt(value, 1, 64);
      } else if (key.text == "stop_time_allowed") {
        cmd.stop_time_allowed_s = ParseInt(value, 0, 3600);
      } else if (key.text == "nickname") {
        // Accepted for compatibility with older sheets: the id already names the command.
      } else {
        Fail(key, "unknown attribute '" + key.text +
                      "' (exec, host, auto_respawn, stop_signal, stop_time_allowed)");
      }
    }
    ExpectSymbol("}");
    const Token end{Token::Kind::kEnd, "", line};
    if (cmd.exec.empty()) Fail(end, "cmd \"" + cmd.id + "\" has no exec");
    if (cmd.host.empty()) Fail(end, "cmd \"" + cmd.id + "\" has no host");
    return cmd;
  }

  int ParseInt(const Token& value, int lo, int hi) const {
    try {
      size_t used = 0;
      const int v = std::stoi(value.text, &used);
      if (used != value.text.size() || v < lo || v > hi) throw std::out_of_range("");
      return v;
    } catch (const std::exception&) {
      Fail(value, "expected an integer in [" + std::to_string(lo) + ", " + std::to_string(hi) +
                      "], found '" + value.text + "'");
    }
  }

  Script ParseScript() {
    Script script;
    script.name = Expect(Token::Kind::kString, "a quoted script name").text;
    ExpectSymbol("{");
    while (!(Peek().kind == Token::Kind::kSymbol && Peek().text == "}")) {
      const Token verb = Expect(Token::Kind::kWord, "a script action");
      ScriptAction a;
      a.line = verb.line;
      if (verb.text == "start" || verb.text == "stop" || verb.text == "restart") {
        a.kind = verb.text == "start"  ? ScriptAction::Kind::kStart
                 : verb.text == "stop" ? ScriptAction::Kind::kStop
                                       : ScriptAction::Kind::kRestart;
        ParseTarget(&a);
        if (Peek().kind == Token::Kind::kWord && Peek().text == "wait") {
          Next();
          a.wait_status = ParseStatus();
          if (a.kind == ScriptAction::Kind::kStop && a.wait_status != "stopped") {
            Fail(verb, "stop can only wait for \"stopped\"");
          }
        }
      } else if (verb.text == "wait") {
        const Token what = Expect(Token::Kind::kWord, "ms, cmd or group");
        if (what.text == "ms") {
          a.kind = ScriptAction::Kind::kWaitMs;
          a.wait_ms = ParseInt(Expect(Token::Kind::kNumber, "milliseconds"), 0, 86400000);
        } else if (what.text == "cmd" || what.text == "group") {
          a.kind = ScriptAction::Kind::kWaitStatus;
          a.target_is_group = what.text == "group";
          a.target = Expect(Token::Kind::kString, "a quoted name").text;
          const Token status = Expect(Token::Kind::kWord, "status");
          if (status.text != "status") Fail(status, "expected 'status'");
          a.wait_status = ParseStatus();
        } else {
          Fail(what, "expected ms, cmd or group after wait");
        }
      } else if (verb.text == "run_script") {
        a.kind = ScriptAction::Kind::kRunScript;
        a.target = Expect(Token::Kind::kString, "a quoted script name").text;
      } else {
        Fail(verb, "unknown script action '" + verb.text + "'");
      }
      ExpectSymbol(";");
      script.actions.push_back(a);
    }
    ExpectSymbol("}");
    return script;
  }

  void ParseTarget(ScriptAction* a) {
    const Token kind = Expect(Token::Kind::kWord, "cmd or group");
    if (kind.text != "cmd" && kind.text != "group") Fail(kind, "expected cmd or group");
    a->target_is_group = kind.text == "group";
    a->target = Expect(Token::Kind::kString, "a quoted name").text;
  }

  std::string ParseStatus() {
    const Token s = Expect(Token::Kind::kString, "\"running\" or \"stopped\"");
    if (s.text != "running" && s.text != "stopped") {
      Fail(s, "expected \"running\" or \"stopped\", found \"" + s.text + "\"");
    }
    return s.text;
  }

  void Check(const Sheet& sheet) const {
    std::set<std::string> ids;
    for (const Command& c : sheet.commands) {
      if (!ids.insert(c.id).second) {
        throw std::runtime_error(file_ + ":" + std::to_string(c.line) + ": duplicate cmd \"" +
                                 c.id + "\"");
      }
    }
    for (const Script& s : sheet.scripts) {
      for (const ScriptAction& a : s.actions) {
        const std::string where = file_ + ":" + std::to_string(a.line) + ": ";
        if (a.kind == ScriptAction::Kind::kWaitMs) continue;
        if (a.kind == ScriptAction::Kind::kRunScript) {
          if (sheet.FindScript(a.target) == nullptr) {
            throw std::runtime_error(where + "unknown script \"" + a.target + "\"");
          }
        } else if (a.target_is_group ? sheet.CommandsInGroup(a.target).empty()
                                     : sheet.FindCommand(a.target) == nullptr) {
          throw std::runtime_error(where + "unknown " + (a.target_is_group ? "group" : "cmd") +
                                   " \"" + a.target + "\"");
        }
      }
    }
  }

  std::vector<Token> t_;
  const std::string& file_;
  size_t i_{0};
};

}  // namespace

const Command* Sheet::FindCommand(const std::string& id) const {
  for (const Command& c : commands) {
    if (c.id == id) return &c;
  }
  return nullptr;
}

std::vector<const Command*> Sheet::CommandsInGroup(const std::string& path) const {
  std::vector<const Command*> out;
  for (const Command& c : commands) {
    if (c.group == path || c.group.rfind(path + "/", 0) == 0) out.push_back(&c);
  }
  return out;
}

const Script* Sheet::FindScript(const std::string& name) const {
  for (const Script& s : scripts) {
    if (s.name == name) return &s;
  }
  return nullptr;
}

Sheet ParseSheet(const std::string& text, const std::string& file_name) {
  Lexer lexer(text, file_name);
  Parser parser(lexer.Tokens(), file_name);
  return parser.Parse();
}

Sheet LoadSheet(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error(path + ": cannot open process sheet");
  std::stringstream text;
  text << in.rdbuf();
  return ParseSheet(text.str(), path);
}

}  // namespace kestrel::procman
