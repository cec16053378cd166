#pragma once
// One table per parameter struct: every parameter is one row holding its name, type, default,
// range, unit, one-line description and whether it is live-tunable. Defaults, validation, the
// YAML / command-line / rosparam readers, the report and the dynamic_reconfigure mapping all read
// the rows, so a parameter is described in exactly one place.

#include <functional>
#include <string>
#include <vector>

#include "flexcloud/types.h"

namespace flexcloud {

enum class ParamType { kReal, kInt, kBool, kText, kChoice, kRanges };

/// A parameter value in neutral form: numbers (integers and booleans too) in `number`, words in
/// `text`, time ranges in `ranges`.
struct ParamValue {
  double number = 0.0;
  std::string text;
  std::vector<TimeRange> ranges;
};

/// Everything about one parameter except where it lives.
struct ParamSpec {
  std::string name;
  ParamType type = ParamType::kReal;
  ParamValue def;
  double min = 0.0;  ///< kReal, kInt
  double max = 0.0;
  bool nan_unset = false;            ///< kReal: NaN means "not given" and is valid
  std::vector<std::string> choices;  ///< kChoice
  std::string unit;                  ///< e.g. "m", "s", "m/s"; empty for counts and words
  std::string doc;                   ///< one line
  bool live = false;                 ///< tunable while running (dynamic_reconfigure)
};

/// What is wrong with `v` as a value of `spec` ("NAME VALUE UNIT is not in [MIN, MAX]"), or "".
std::string checkValue(const ParamSpec& spec, const ParamValue& v);
/// Parses text: a number, true/false, a word, or "begin:end[,begin:end...]" for ranges. Throws
/// Error "NAME: 'TEXT' is not ..." when the text is not a value of the type (ranges and choices
/// are checked by checkValue()).
ParamValue parseValue(const ParamSpec& spec, const std::string& text);
/// Parses "begin:end[,begin:end...]" (seconds); throws Error "NAME: ..." otherwise.
std::vector<TimeRange> parseTimeRanges(const std::string& name, const std::string& text);
/// The value as text, the way parseValue() reads it back.
std::string formatValue(const ParamSpec& spec, const ParamValue& v);
/// The type's name as the docs and dynamic_reconfigure spell it: double, int, bool, str, ranges.
std::string typeName(ParamType type);

/// One parameter of struct S: its spec and how to read and write it in an S.
template <class S>
struct ParamRow {
  ParamSpec spec;
  std::function<ParamValue(const S&)> get;
  std::function<void(S&, const ParamValue&)> set;
};

template <class S>
class ParamTable {
 public:
  explicit ParamTable(std::vector<ParamRow<S>> rows) : rows_(std::move(rows)) {}

  const std::vector<ParamRow<S>>& rows() const { return rows_; }
  const ParamRow<S>* find(const std::string& name) const {
    for (const auto& r : rows_) {
      if (r.spec.name == name) return &r;
    }
    return nullptr;
  }
  const ParamRow<S>& row(const std::string& name) const {
    const ParamRow<S>* r = find(name);
    if (r == nullptr) throw Error("unknown parameter '" + name + "'");
    return *r;
  }
  void setDefaults(S& s) const {
    for (const auto& r : rows_) r.set(s, r.spec.def);
  }
  /// Sets a parameter; throws Error for an unknown name (the range is checked by validate()).
  void set(S& s, const std::string& name, const ParamValue& v) const { row(name).set(s, v); }
  /// Sets a parameter from text; throws Error naming the key when it is unknown or the text is
  /// not a value of its type.
  void setText(S& s, const std::string& name, const std::string& text) const {
    const auto& r = row(name);
    r.set(s, parseValue(r.spec, text));
  }
  /// A parameter's value as text (formatValue); throws Error for an unknown name.
  std::string text(const S& s, const std::string& name) const {
    const auto& r = row(name);
    return formatValue(r.spec, r.get(s));
  }
  /// Every value out of its range or choices, joined by "; "; empty when all are fine.
  std::string validate(const S& s) const {
    std::string out;
    for (const auto& r : rows_) {
      const std::string bad = checkValue(r.spec, r.get(s));
      if (!bad.empty()) out += (out.empty() ? "" : "; ") + bad;
    }
    return out;
  }
  /// Whether every parameter of a and b has the same value (NaN equals NaN).
  bool same(const S& a, const S& b) const {
    for (const auto& r : rows_) {
      if (formatValue(r.spec, r.get(a)) != formatValue(r.spec, r.get(b))) return false;
    }
    return true;
  }
  /// The same rows, reached in an Outer through its member of type S.
  template <class Outer>
  std::vector<ParamRow<Outer>> lifted(S Outer::*member) const {
    std::vector<ParamRow<Outer>> out;
    for (const auto& r : rows_) {
      out.push_back({r.spec, [get = r.get, member](const Outer& o) { return get(o.*member); },
                     [set = r.set, member](Outer& o, const ParamValue& v) { set(o.*member, v); }});
    }
    return out;
  }

 private:
  std::vector<ParamRow<S>> rows_;
};

/// Whether the parameter can be tuned live.
enum class Live { kNo, kYes };

// Row builders for the common field types.
template <class S>
ParamRow<S> realRow(const char* name, double S::*m, double def, double min, double max,
                    const char* unit, const char* doc, Live live = Live::kNo) {
  ParamSpec spec{name, ParamType::kReal,  {def, "", {}}, min, max, false, {}, unit,
                 doc,  live == Live::kYes};
  return {spec,
          [m](const S& s) {
            return ParamValue{s.*m, "", {}};
          },
          [m](S& s, const ParamValue& v) { s.*m = v.number; }};
}

template <class S>
ParamRow<S> intRow(const char* name, int S::*m, int def, int min, int max, const char* unit,
                   const char* doc, Live live = Live::kNo) {
  ParamSpec spec{name,
                 ParamType::kInt,
                 {static_cast<double>(def), "", {}},
                 static_cast<double>(min),
                 static_cast<double>(max),
                 false,
                 {},
                 unit,
                 doc,
                 live == Live::kYes};
  return {spec,
          [m](const S& s) {
            return ParamValue{static_cast<double>(s.*m), "", {}};
          },
          [m](S& s, const ParamValue& v) { s.*m = static_cast<int>(v.number); }};
}

template <class S>
ParamRow<S> boolRow(const char* name, bool S::*m, bool def, const char* doc,
                    Live live = Live::kNo) {
  ParamSpec spec{name, ParamType::kBool,  {def ? 1.0 : 0.0, "", {}}, 0, 1, false, {}, "",
                 doc,  live == Live::kYes};
  return {spec,
          [m](const S& s) {
            return ParamValue{s.*m ? 1.0 : 0.0, "", {}};
          },
          [m](S& s, const ParamValue& v) { s.*m = v.number != 0.0; }};
}

template <class S>
ParamRow<S> textRow(const char* name, std::string S::*m, const char* def, const char* doc) {
  ParamSpec spec{name, ParamType::kText, {0.0, def, {}}, 0, 0, false, {}, "", doc, false};
  return {spec,
          [m](const S& s) {
            return ParamValue{0.0, s.*m, {}};
          },
          [m](S& s, const ParamValue& v) { s.*m = v.text; }};
}

template <class S>
ParamRow<S> choiceRow(const char* name, std::string S::*m, const char* def,
                      std::vector<std::string> choices, const char* doc, Live live = Live::kNo) {
  ParamSpec spec{name, ParamType::kChoice, {0.0, def, {}}, 0, 0, false, std::move(choices), "",
                 doc,  live == Live::kYes};
  return {spec,
          [m](const S& s) {
            return ParamValue{0.0, s.*m, {}};
          },
          [m](S& s, const ParamValue& v) { s.*m = v.text; }};
}

template <class S>
ParamRow<S> rangesRow(const char* name, std::vector<TimeRange> S::*m, const char* unit,
                      const char* doc) {
  ParamSpec spec{name, ParamType::kRanges, {}, 0, 0, false, {}, unit, doc, false};
  return {spec,
          [m](const S& s) {
            return ParamValue{0.0, "", s.*m};
          },
          [m](S& s, const ParamValue& v) { s.*m = v.ranges; }};
}

}  // namespace flexcloud
