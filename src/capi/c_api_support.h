#pragma once
// What the C API's files share (private to src/capi): the guard that turns every exception into
// a status and the thread's last error, and the checks of the caller's pointers and buffers.
#include <Eigen/Core>
#include <cmath>
#include <exception>
#include <memory>
#include <new>
#include <string>

#include "lamina/c_api.h"
#include "lamina/core/error.h"
#include "lamina/model/model.h"

// A model handle: the library's model, shared with the simulations and worlds made on it.
struct lamina_model {
  std::shared_ptr<const lamina::Model> model;
};

namespace lamina::capi {

inline std::string& last_error() {
  thread_local std::string message;
  return message;
}

// Runs `body`, mapping whatever it throws to a status and a one-line message.
template <class Body>
lamina_status guarded(Body&& body) {
  try {
    body();
    last_error().clear();
    return LAMINA_OK;
  } catch (const Error& e) {
    last_error() = e.what();
    return static_cast<lamina_status>(e.exit_code());
  } catch (const std::bad_alloc&) {
    last_error() = "out of memory";
  } catch (const std::exception& e) {
    last_error() = e.what();
  } catch (...) {
    last_error() = "unknown error";
  }
  return LAMINA_ERROR_INTERNAL;
}

template <class T>
T& need(T* handle, const char* what) {
  if (handle == nullptr) throw invalid_input(what, "is NULL");
  return *handle;
}

inline std::string need_text(const char* text, const char* what) {
  if (text == nullptr) throw invalid_input(what, "is NULL");
  return text;
}

inline void need_capacity(int64_t capacity, int64_t needed, const char* what) {
  if (capacity < needed)
    throw invalid_input(what, "holds " + std::to_string(capacity) + " values; " +
                                  std::to_string(needed) + " are needed");
}

inline void need_finite(const double* v, int n, const char* what) {
  for (int k = 0; k < n; ++k)
    if (!std::isfinite(v[k])) throw invalid_input(what, "is not finite");
}

inline void copy_points(const Eigen::MatrixX3d& p, double* xyz) {
  for (Eigen::Index i = 0; i < p.rows(); ++i)
    for (int c = 0; c < 3; ++c) xyz[3 * i + c] = p(i, c);
}

}  // namespace lamina::capi
