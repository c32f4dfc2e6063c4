#pragma once
/// @file interrupt.hpp
/// Cooperative interruption of long core calls (Ctrl-C from Python). Loops whose length a user
/// chooses (Newton, CG and local/global iterations, multi-step advance, stroke sampling) call
/// poll_interrupt(); while an InterruptScope is alive on the calling thread, poll_interrupt()
/// asks the scope's check at most once per period of wall time and throws Interrupted when the
/// check says so. Without a scope (plain C++ use, OpenMP workers) a poll is one load and a
/// branch. Never call poll_interrupt() inside an OpenMP parallel region.

#include <chrono>
#include <functional>
#include <stdexcept>
#include <utility>

namespace yore {

/// Thrown by poll_interrupt() when the installed check asks to stop. Integrators undo the
/// interrupted advance() call (the cloth is back at its state before that call) before it
/// leaves them.
class Interrupted : public std::runtime_error {
 public:
  Interrupted() : std::runtime_error("interrupted") {}
};

namespace detail {
struct InterruptState {
  const std::function<bool()>* check = nullptr;
  std::chrono::steady_clock::duration period{};
  std::chrono::steady_clock::time_point next{};
};
inline thread_local InterruptState interrupt_state;
}  // namespace detail

/// Installs `check` for the calling thread while alive (scopes nest; the innermost wins).
/// check() runs at most once per `period` of wall time and returns true to interrupt.
class InterruptScope {
 public:
  explicit InterruptScope(std::function<bool()> check, std::chrono::steady_clock::duration period =
                                                           std::chrono::milliseconds(50))
      : m_check(std::move(check)), m_saved(detail::interrupt_state) {
    detail::interrupt_state.check = &m_check;
    detail::interrupt_state.period = period;
    detail::interrupt_state.next = std::chrono::steady_clock::now() + period;
  }
  ~InterruptScope() { detail::interrupt_state = m_saved; }
  InterruptScope(const InterruptScope&) = delete;
  InterruptScope& operator=(const InterruptScope&) = delete;

 private:
  std::function<bool()> m_check;
  detail::InterruptState m_saved;
};

/// Throws Interrupted if the calling thread's InterruptScope check, asked at most once per its
/// period, says so. Costs one clock read (~20 ns) while a scope is installed, nothing otherwise.
inline void poll_interrupt() {
  detail::InterruptState& state = detail::interrupt_state;
  if (state.check == nullptr) return;
  const auto now = std::chrono::steady_clock::now();
  if (now < state.next) return;
  // Checked from the time the check returns: a slow check (waiting for a lock) cannot starve
  // the computation.
  const bool stop = (*state.check)();
  state.next = std::chrono::steady_clock::now() + state.period;
  if (stop) throw Interrupted();
}

}  // namespace yore
