#include "convert.hpp"

#include <atomic>
#include <limits>
#include <mutex>
#include <sstream>
#include <stdexcept>
#include <unordered_map>

namespace yore::bindings {
namespace {

/// The objects BusyGuards hold, with the call that holds each. Bindings take and release marks
/// with the GIL held; the mutex keeps the table sound without it (free-threaded builds).
struct BusyTable {
  std::mutex mutex;
  std::unordered_map<const void*, const char*> calls;
  std::atomic<std::size_t> size{0};  // lock-free fast path of check_idle
};

BusyTable& busy_table() {
  static BusyTable* table = new BusyTable();  // never destroyed: no exit-order issues
  return *table;
}

}  // namespace

BusyGuard::BusyGuard(const void* object, const char* what, const char* call) : m_object(object) {
  BusyTable& table = busy_table();
  const std::lock_guard<std::mutex> lock(table.mutex);
  const auto [it, inserted] = table.calls.emplace(object, call);
  if (!inserted) {
    throw std::runtime_error(std::string(what) + " is in use by another thread (" + it->second +
                             "); wait for that call to finish");
  }
  table.size.store(table.calls.size(), std::memory_order_release);
}

BusyGuard::~BusyGuard() {
  BusyTable& table = busy_table();
  const std::lock_guard<std::mutex> lock(table.mutex);
  table.calls.erase(m_object);
  table.size.store(table.calls.size(), std::memory_order_release);
}

void check_idle(const void* object, const char* what) {
  BusyTable& table = busy_table();
  if (table.size.load(std::memory_order_acquire) == 0) return;
  const std::lock_guard<std::mutex> lock(table.mutex);
  const auto it = table.calls.find(object);
  if (it != table.calls.end()) {
    throw std::runtime_error(std::string(what) + " is in use by another thread (" + it->second +
                             "); wait for that call to finish");
  }
}

bool is_busy(const void* object) {
  BusyTable& table = busy_table();
  if (table.size.load(std::memory_order_acquire) == 0) return false;
  const std::lock_guard<std::mutex> lock(table.mutex);
  return table.calls.count(object) > 0;
}

PendingPythonError::~PendingPythonError() {
  // Only reached with the GIL held (run_without_gil's frame).
  Py_XDECREF(m_type);
  Py_XDECREF(m_value);
  Py_XDECREF(m_traceback);
}

bool PendingPythonError::check_signals() {
  if (PyErr_CheckSignals() == 0) return false;
  PyErr_Fetch(&m_type, &m_value, &m_traceback);
  return true;
}

void PendingPythonError::raise() {
  if (m_type == nullptr) {
    PyErr_SetNone(PyExc_KeyboardInterrupt);
  } else {
    PyErr_Restore(m_type, m_value, m_traceback);  // steals the references
    m_type = m_value = m_traceback = nullptr;
  }
  throw py::error_already_set();
}

std::string shape_text(const py::array& array) {
  std::ostringstream text;
  text << "(";
  for (py::ssize_t d = 0; d < array.ndim(); ++d) {
    text << (d ? ", " : "") << array.shape(d);
  }
  text << (array.ndim() == 1 ? ",)" : ")");
  return text.str();
}

py::array_t<double, py::array::c_style | py::array::forcecast> as_float_array(
    const py::handle& object, const char* name) {
  py::array numeric;
  try {
    numeric = py::module_::import("numpy").attr("asarray")(object);
  } catch (const py::error_already_set& error) {
    throw std::invalid_argument(std::string(name) + " is not an array: " + error.what());
  }
  const char kind = numeric.dtype().kind();
  if (kind != 'f' && kind != 'i' && kind != 'u' && kind != 'b') {
    throw std::invalid_argument(std::string(name) + " must be a numeric array, got dtype " +
                                std::string(py::str(numeric.dtype())));
  }
  return py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(numeric);
}

Positions to_rows3(const py::handle& object, const char* name, Eigen::Index rows) {
  const auto array = as_float_array(object, name);
  if (array.ndim() != 2 || array.shape(1) != 3 || (rows >= 0 && array.shape(0) != rows)) {
    std::ostringstream msg;
    msg << name << " must have shape (" << (rows >= 0 ? std::to_string(rows) : std::string("n"))
        << ", 3), got " << shape_text(array);
    throw std::invalid_argument(msg.str());
  }
  Positions out(array.shape(0), 3);
  std::copy(array.data(), array.data() + array.size(), out.data());
  return out;
}

namespace {

/// Copies an integer array into `out` (numeric.size() entries) as int32, in C order.
void narrow_to_int32(const py::array& numeric, const char* name, std::int32_t* out) {
  if (numeric.dtype().kind() == 'u') {  // uint64 above 2^63 would wrap to negative int64
    const auto wide =
        py::array_t<std::uint64_t, py::array::c_style | py::array::forcecast>::ensure(numeric);
    for (py::ssize_t k = 0; k < wide.size(); ++k) {
      const std::uint64_t value = wide.data()[k];
      if (value > static_cast<std::uint64_t>(std::numeric_limits<std::int32_t>::max())) {
        std::ostringstream msg;
        msg << name << " holds the index " << value << ", outside the 32-bit range";
        throw std::invalid_argument(msg.str());
      }
      out[k] = static_cast<std::int32_t>(value);
    }
    return;
  }
  const auto wide =
      py::array_t<std::int64_t, py::array::c_style | py::array::forcecast>::ensure(numeric);
  for (py::ssize_t k = 0; k < wide.size(); ++k) {
    const std::int64_t value = wide.data()[k];
    if (value < std::numeric_limits<std::int32_t>::min() ||
        value > std::numeric_limits<std::int32_t>::max()) {
      std::ostringstream msg;
      msg << name << " holds the index " << value << ", outside the 32-bit range";
      throw std::invalid_argument(msg.str());
    }
    out[k] = static_cast<std::int32_t>(value);
  }
}

template <int Columns>
Eigen::Matrix<std::int32_t, Eigen::Dynamic, Columns, Eigen::RowMajor> to_index_rows(
    const py::handle& object, const char* name) {
  py::array numeric = py::module_::import("numpy").attr("asarray")(object);
  const char kind = numeric.dtype().kind();
  if (kind != 'i' && kind != 'u' && !(kind == 'f' && numeric.size() == 0)) {
    throw std::invalid_argument(std::string(name) + " must be an integer array, got dtype " +
                                std::string(py::str(numeric.dtype())));
  }
  if (numeric.ndim() != 2 || numeric.shape(1) != Columns) {
    std::ostringstream msg;
    msg << name << " must have shape (n, " << Columns << "), got " << shape_text(numeric);
    throw std::invalid_argument(msg.str());
  }
  Eigen::Matrix<std::int32_t, Eigen::Dynamic, Columns, Eigen::RowMajor> out(numeric.shape(0),
                                                                            Columns);
  narrow_to_int32(numeric, name, out.data());
  return out;
}

}  // namespace

std::int32_t to_int32(std::int64_t value, const char* name) {
  if (value < std::numeric_limits<std::int32_t>::min() ||
      value > std::numeric_limits<std::int32_t>::max()) {
    std::ostringstream msg;
    msg << name << " = " << value << " is outside the 32-bit range";
    throw std::invalid_argument(msg.str());
  }
  return static_cast<std::int32_t>(value);
}

Faces to_faces(const py::handle& object, const char* name) {
  return to_index_rows<3>(object, name);
}

Edges to_edges(const py::handle& object, const char* name) {
  return to_index_rows<2>(object, name);
}

Eigen::VectorXd to_vector(const py::handle& object, const char* name, Eigen::Index size) {
  const auto array = as_float_array(object, name);
  if (array.ndim() != 1 || (size >= 0 && array.shape(0) != size)) {
    std::ostringstream msg;
    msg << name << " must have shape (" << (size >= 0 ? std::to_string(size) : std::string("n"))
        << ",), got " << shape_text(array);
    throw std::invalid_argument(msg.str());
  }
  Eigen::VectorXd out(array.shape(0));
  std::copy(array.data(), array.data() + array.size(), out.data());
  return out;
}

Eigen::Vector3d to_vec3(const py::handle& object, const char* name) {
  const Eigen::VectorXd values = to_vector(object, name, 3);
  return values;
}

std::vector<std::int32_t> to_indices(const py::handle& object, const char* name) {
  py::array numeric = py::module_::import("numpy").attr("atleast_1d")(
      py::module_::import("numpy").attr("asarray")(object));
  const char kind = numeric.dtype().kind();
  if (numeric.size() > 0 && kind != 'i' && kind != 'u') {
    throw std::invalid_argument(std::string(name) + " must be integer vertex indices, got dtype " +
                                std::string(py::str(numeric.dtype())));
  }
  if (numeric.ndim() != 1) {
    throw std::invalid_argument(std::string(name) + " must be a 1-D list of indices, got shape " +
                                shape_text(numeric));
  }
  std::vector<std::int32_t> out(static_cast<std::size_t>(numeric.size()));
  narrow_to_int32(numeric, name, out.data());
  return out;
}

}  // namespace yore::bindings

namespace yore::bindings {

void bind_statistics(py::module_& m) {
  py::class_<Statistics>(m, "Statistics", R"doc(
An integrator's statistics: steps (taken), phases ({name: cumulative wall seconds}) and counters
({name: cumulative count or the last step's figure}). Read-only; phases and counters are copies.)doc")
      .def_readonly("steps", &Statistics::steps)
      .def_property_readonly("phases", [](const Statistics& s) { return s.phases.attr("copy")(); })
      .def_property_readonly("counters",
                             [](const Statistics& s) { return s.counters.attr("copy")(); })
      .def("__repr__", [](const Statistics& s) {
        return "Statistics(steps=" + std::to_string(s.steps) + ", " +
               std::to_string(py::len(s.phases)) + " phases, " +
               std::to_string(py::len(s.counters)) + " counters)";
      });
}

}  // namespace yore::bindings
