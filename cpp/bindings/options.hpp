#pragma once
// Integrator options across the boundary: one table per C++ option struct names each option
// once (its Python name), reads it from a struct and writes it into one. The integrators'
// constructors take keyword arguments through the table, and `Integrator.defaults` is the
// table applied to a default-constructed struct, so every default lives in the C++ struct and
// the Python option tables are built from it.

#include "convert.hpp"

#include <functional>
#include <initializer_list>
#include <string>
#include <utility>
#include <vector>

namespace yore::bindings {

template <typename Options>
struct OptionField {
  std::string name;
  std::function<py::object(const Options&)> get;
  std::function<void(Options&, const py::handle&)> set;
};

template <typename Options>
using OptionTable = std::vector<OptionField<Options>>;

/// A double, bool, 32-bit int or string member, under `name`.
template <typename Options, typename Holder, typename T>
OptionField<Options> plain_option(const char* name, Holder Options::*holder, T Holder::*member) {
  const std::string key = name;
  return {key,
          [=](const Options& o) { return py::cast((o.*holder).*member); },
          [=](Options& o, const py::handle& value) {
            if constexpr (std::is_same_v<T, int>) {
              (o.*holder).*member = to_int32(value.cast<std::int64_t>(), key.c_str());
            } else {
              (o.*holder).*member = value.cast<T>();
            }
          }};
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
          }};
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
          }};
}

/// The struct's values by their Python names.
template <typename Options>
py::dict option_values(const OptionTable<Options>& table, const Options& options) {
  py::dict out;
  for (const auto& field : table) out[py::str(field.name)] = field.get(options);
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
