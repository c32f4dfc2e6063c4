#pragma once
// Integrator options across the boundary: one table per C++ option struct names each option
// once (its Python name), reads it from a struct and writes it into one. The integrators'
// constructors take keyword arguments through the table, and `Integrator.defaults` is the
// table applied to a default-constructed struct, so every default lives in the C++ struct and
// the Python option tables are built from it.

#include <cmath>
#include <functional>
#include <initializer_list>
#include <limits>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "convert.hpp"

namespace yore::bindings {

/// Largest iteration counts an option may ask for: one step runs its iterations inside the
/// core, out of reach of Ctrl-C, so a typo such as 10**9 iterations is refused.
inline constexpr double kMaxStepIterations = 10'000;  ///< per step (Newton, CG, passes)
/// Smallest rtol of the error-controlled steps: below it the local error test compares
/// round-off (positions of order 1 m carry ~1e-16 m) and Newton's stop, not truncation: CVODE at
/// 1e-14 on a 6×6 cloth was still in its first 1/60 s interval after two minutes.
inline constexpr double kMinRelativeTolerance = 1e-12;
inline constexpr double kMaxSolverIterations = 1'000'000;  ///< per linear solve (pcg)
inline constexpr double kMaxLbfgsHistory = 1'000;

/// What values an option takes, for the Python side's checks (yore.options reads it as
/// `Integrator.option_rules`): "flag" (a bool), "count" (an integer in [low, high]), "real" (a
/// finite number between low and high, each bound open or closed; high may be infinite) or
/// "choice" (one of `choices`).
struct OptionRule {
  std::string kind;
  double low = 0.0;
  double high = std::numeric_limits<double>::infinity();
  bool low_open = true;
  bool high_open = false;
  std::vector<std::string> choices;
};

template <typename Options>
struct OptionField {
  std::string name;
  std::function<py::object(const Options&)> get;
  std::function<void(Options&, const py::handle&)> set;
  OptionRule rule;
};

/// The rule a plain member of type T gets before a range is given: bools are flags, integers
/// counts from 1 up to kMaxStepIterations, doubles positive reals, strings choices.
template <typename T>
OptionRule default_rule() {
  OptionRule rule;
  if constexpr (std::is_same_v<T, bool>) {
    rule.kind = "flag";
  } else if constexpr (std::is_same_v<T, int>) {
    rule.kind = "count";
    rule.low = 1.0;
    rule.high = kMaxStepIterations;
  } else if constexpr (std::is_same_v<T, double>) {
    rule.kind = "real";
  } else {
    rule.kind = "choice";
  }
  return rule;
}

/// `field` taking values between low and high (a count: [low, high]; a real: open or closed
/// bounds as given).
template <typename Options>
OptionField<Options> in_range(OptionField<Options> field, double low, double high,
                              bool low_open = true, bool high_open = false) {
  field.rule.low = low;
  field.rule.high = high;
  field.rule.low_open = low_open;
  field.rule.high_open = high_open;
  return field;
}

/// A string `field` taking one of `choices`.
template <typename Options>
OptionField<Options> one_of(OptionField<Options> field, std::vector<std::string> choices) {
  field.rule.kind = "choice";
  field.rule.choices = std::move(choices);
  return field;
}

template <typename Options>
using OptionTable = std::vector<OptionField<Options>>;

/// Binds `Options` as the Python class `name` with one read-only property per field of
/// `table` (its Python name, its value as the table reads it): an integrator's options as
/// they cross the boundary. `table` must outlive the module (the bindings' tables are static).
template <typename Options>
void bind_options_class(py::module_& m, const char* name, const OptionTable<Options>& table) {
  py::class_<Options> options_class(m, name,
                                    "An integrator's options, read-only (see `defaults`).");
  for (const OptionField<Options>& field : table) {
    const auto get = field.get;
    options_class.def_property_readonly(field.name.c_str(),
                                        [get](const Options& o) { return get(o); });
  }
  options_class.def("__repr__", [name, &table](const Options& o) {
    std::string text = std::string(name) + "(";
    for (std::size_t k = 0; k < table.size(); ++k) {
      if (k) text += ", ";
      text += table[k].name + "=" + py::repr(table[k].get(o)).template cast<std::string>();
    }
    return text + ")";
  });
}

/// A double, bool, 32-bit int or string member, under `name`.
template <typename Options, typename Holder, typename T>
OptionField<Options> plain_option(const char* name, Holder Options::*holder, T Holder::*member) {
  const std::string key = name;
  return {key, [=](const Options& o) { return py::cast((o.*holder).*member); },
          [=](Options& o, const py::handle& value) {
            if constexpr (std::is_same_v<T, int>) {
              (o.*holder).*member = to_int32(value.cast<std::int64_t>(), key.c_str());
            } else {
              (o.*holder).*member = value.cast<T>();
            }
          },
          default_rule<T>()};
}

template <typename Options, typename T>
OptionField<Options> plain_option(const char* name, T Options::*member) {
  const std::string key = name;
  return {key, [=](const Options& o) { return py::cast(o.*member); },
          [=](Options& o, const py::handle& value) {
            if constexpr (std::is_same_v<T, int>) {
              o.*member = to_int32(value.cast<std::int64_t>(), key.c_str());
            } else {
              o.*member = value.cast<T>();
            }
          },
          default_rule<T>()};
}

/// An enum reached by `access`, by the names of `choices` (std::invalid_argument listing them).
template <typename Options, typename Enum>
OptionField<Options> choice_option(const char* name, std::function<Enum&(Options&)> access,
                                   std::vector<std::pair<std::string, Enum>> choices) {
  const std::string key = name;
  return {key,
          [=](const Options& o) -> py::object {
            const Enum value = access(const_cast<Options&>(o));
            for (const auto& [text, code] : choices) {
              if (code == value) return py::str(text);
            }
            return py::none();
          },
          [=](Options& o, const py::handle& value) {
            const std::string text = value.cast<std::string>();
            std::string valid;
            for (const auto& [choice, code] : choices) {
              if (choice == text) {
                access(o) = code;
                return;
              }
              valid += (valid.empty() ? "" : ", ") + choice;
            }
            throw std::invalid_argument("unknown " + key + " '" + text + "'; valid: " + valid);
          },
          [&] {
            OptionRule rule;
            rule.kind = "choice";
            for (const auto& [text, code] : choices) rule.choices.push_back(text);
            return rule;
          }()};
}

/// The struct's values by their Python names.
template <typename Options>
py::dict option_values(const OptionTable<Options>& table, const Options& options) {
  py::dict out;
  for (const auto& field : table) out[py::str(field.name)] = field.get(options);
  return out;
}

/// Every option's rule by its Python name: {kind, low, high (None: infinite), low_open,
/// high_open, choices}.
template <typename Options>
py::dict option_rules(const OptionTable<Options>& table) {
  py::dict out;
  for (const auto& field : table) {
    const OptionRule& rule = field.rule;
    py::dict entry;
    entry["kind"] = rule.kind;
    entry["low"] = rule.low;
    entry["high"] =
        std::isinf(rule.high) ? py::object(py::none()) : py::object(py::float_(rule.high));
    entry["low_open"] = rule.low_open;
    entry["high_open"] = rule.high_open;
    py::list choices;
    for (const std::string& choice : rule.choices) choices.append(py::str(choice));
    entry["choices"] = py::tuple(choices);
    out[py::str(field.name)] = entry;
  }
  return out;
}

/// A default struct with the keyword arguments applied; an unknown name is a ValueError listing
/// the valid ones.
template <typename Options>
Options options_from_kwargs(const OptionTable<Options>& table, const py::kwargs& kwargs) {
  Options options;
  for (const auto& [key, value] : kwargs) {
    const std::string name = py::cast<std::string>(key);
    bool found = false;
    for (const auto& field : table) {
      if (field.name == name) {
        field.set(options, value);
        found = true;
        break;
      }
    }
    if (!found) {
      std::string valid;
      for (const auto& field : table) valid += (valid.empty() ? "" : ", ") + field.name;
      throw std::invalid_argument("unknown option '" + name + "'; valid: " + valid);
    }
  }
  return options;
}

}  // namespace yore::bindings
