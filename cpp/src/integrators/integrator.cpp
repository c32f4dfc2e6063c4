#include "yore/integrators/integrator.hpp"

#include <cmath>
#include <sstream>
#include <stdexcept>

#include "yore/integrators/time_scheme.hpp"

namespace yore {

std::vector<std::string> integrator_names() {
  std::vector<std::string> names{integrator_name::kExplicit};
  for (const TimeSchemeRow& row : time_schemes()) names.emplace_back(row.integrator);
  for (const char* name : {integrator_name::kQuasiNewton, integrator_name::kLocalGlobal,
                           integrator_name::kCvode, integrator_name::kArkode}) {
    names.emplace_back(name);
  }
  return names;
}

const Positions& IntegratorHistory::array(const std::string& name) const {
  for (const auto& [key, values] : arrays) {
    if (key == name) return values;
  }
  throw std::invalid_argument("history has no array '" + name + "'");
}

IntegratorHistory Integrator::history(const Cloth&) const { return {}; }

void Integrator::set_history(const Cloth& cloth, const IntegratorHistory& history) {
  check_history(cloth, history);
}

void Integrator::check_history(const Cloth& cloth, const IntegratorHistory& history) const {
  if (!history.valid) return;
  const std::vector<std::string> fields = history_fields();
  if (fields.empty()) throw std::invalid_argument("this integrator keeps no history to restore");
  for (const std::string& name : fields) {
    const Positions& values = history.array(name);
    if (values.rows() != cloth.vertex_count()) {
      std::ostringstream msg;
      msg << "history " << name << " must have " << cloth.vertex_count()
          << " rows (the cloth's vertices), got " << values.rows();
      throw std::invalid_argument(msg.str());
    }
    if (!values.allFinite()) throw std::invalid_argument("history " + name + " must be finite");
  }
  if (!std::isfinite(history.dt) || history.dt <= 0.0) {
    std::ostringstream msg;
    msg << "history dt must be finite and > 0, got " << history.dt;
    throw std::invalid_argument(msg.str());
  }
  if (!std::isfinite(history.next_dt) || history.next_dt < 0.0) {
    std::ostringstream msg;
    msg << "history next_dt must be finite and >= 0, got " << history.next_dt;
    throw std::invalid_argument(msg.str());
  }
}

}  // namespace yore
