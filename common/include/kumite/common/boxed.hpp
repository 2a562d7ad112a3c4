#pragma once
// Boxed<T>: a T held by value semantics (copies are deep, == compares the values) whose type may
// be incomplete where the box is declared, copied, compared or destroyed. Only the code that
// reads or writes the T (operator*, operator->, assignment from a T) needs T's definition.
//
// What it is for: a plain config struct (app/config.hpp) that carries another module's tunables
// without including their header, so that adding a tunable recompiles the units that use it and
// not every unit that includes the config (C++26's std::indirect does the same, less the
// incomplete type at copy and compare, which it takes from a complete type's instantiation).
//
// An empty box (default-constructed) reads as a default-constructed T and compares equal to one;
// the first write through a non-const operator* allocates it. Copying and comparing go through
// functions taken where T was complete (the first write, or construction from a T).
#include <utility>

namespace kumite {

template <typename T>
class Boxed {
 public:
  Boxed() noexcept = default;
  Boxed(const T& value) : value_(new T(value)), ops_(ops()) {}  // NOLINT: implicit, as a T member would take one
  Boxed(const Boxed& other) : value_(other.value_ ? other.ops_->clone(other.value_) : nullptr), ops_(other.ops_) {}
  Boxed(Boxed&& other) noexcept : value_(std::exchange(other.value_, nullptr)), ops_(other.ops_) {}
  Boxed& operator=(Boxed other) noexcept {
    std::swap(value_, other.value_);
    std::swap(ops_, other.ops_);
    return *this;
  }
  Boxed& operator=(const T& value) {
    **this = value;
    return *this;
  }
  ~Boxed() {
    if (value_) ops_->destroy(value_);
  }

  /// The value (an empty box's: allocated here, default-constructed).
  T& operator*() {
    if (!value_) {
      value_ = new T();
      ops_ = ops();
    }
    return *value_;
  }
  /// The value (an empty box's: a default-constructed T, shared and never written).
  const T& operator*() const {
    if (value_) return *value_;
    static const T kDefault{};
    return kDefault;
  }
  T* operator->() { return &**this; }
  const T* operator->() const { return &**this; }

  friend bool operator==(const Boxed& a, const Boxed& b) {
    if (!a.value_ && !b.value_) return true;
    const Ops* o = a.value_ ? a.ops_ : b.ops_;
    return o->equal(a.value_, b.value_);
  }

 private:
  struct Ops {
    T* (*clone)(const T*);
    void (*destroy)(T*);
    bool (*equal)(const T*, const T*);  ///< a null side: a default-constructed T
  };
  // Instantiated only by the members that need T complete (construction from a T, writing).
  static const Ops* ops() {
    static const Ops kOps{
        [](const T* v) { return new T(*v); },
        [](T* v) { delete v; },
        [](const T* a, const T* b) {
          const T d{};
          return (a ? *a : d) == (b ? *b : d);
        },
    };
    return &kOps;
  }

  T* value_ = nullptr;
  const Ops* ops_ = nullptr;
};

}  // namespace kumite
