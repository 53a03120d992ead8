// One registry of named things (laws, blend rules, grid schemes): every kind is looked up, listed,
// refused and reported the same way, so a message or a lock fixed for one is fixed for all.
//
// Info is an aggregate with at least `std::string name` and a factory `make` (a std::function);
// whatever else it carries (a summary, traits) travels with it. Entries are kept sorted by name, so
// listings are reproducible whatever the order of static initialization.
//
// Thread safety: entries are added from static initializers, but also later (plugins, validation/
// src/plugin_loader.cpp; tests add and remove entries) while other threads look entries up, so
// every access takes the lock: shared for lookups, exclusive for add/remove. Factories run outside
// the lock: a factory may itself look up entries (a blend building its inner law), and a slow
// factory must not stall other threads' lookups.
#pragma once

#include <map>
#include <mutex>
#include <optional>
#include <shared_mutex>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "glintlab/base/errors.hpp"

namespace glintlab {

template <class Info>
class Registry {
 public:
  // `kind` names the entries in messages: "law", "blend", "grid scheme".
  explicit Registry(std::string kind) : kind_(std::move(kind)) {}
  Registry(const Registry&) = delete;
  Registry& operator=(const Registry&) = delete;

  const std::string& kind() const { return kind_; }

  // Adds `info` under info.name. A second entry of the same name is a programming error (two files
  // claiming one name, or a plugin loaded over a built-in), never silently shadowed:
  // std::logic_error "<kind> registered twice: <name>". Returns true, so that a static initializer
  // can read `const bool registered = registry.add(...)`.
  bool add(Info info) {
    if (info.name.empty()) throw std::logic_error(kind_ + " registered without a name");
    std::unique_lock lock(mutex_);
    if (entries_.count(info.name)) throw std::logic_error(kind_ + " registered twice: " + info.name);
    std::string key = info.name;
    entries_.emplace(std::move(key), std::move(info));
    return true;
  }

  // Removes `name`; returns whether it was there. Objects already made by its factory stay valid
  // (they do not point back into the registry). Used by tests that add a law for the length of a
  // test, and available to plugin hosts.
  bool remove(const std::string& name) {
    std::unique_lock lock(mutex_);
    return entries_.erase(name) > 0;
  }

  bool contains(const std::string& name) const {
    std::shared_lock lock(mutex_);
    return entries_.count(name) > 0;
  }

  // A copy of the entry (so the caller holds no reference into a map another thread may change);
  // std::invalid_argument "unknown <kind> '<name>'; known: a, b, c" when there is none.
  Info find(const std::string& name) const {
    std::shared_lock lock(mutex_);
    const auto it = entries_.find(name);
    if (it == entries_.end()) throw_invalid_message(unknown_message_locked(name));
    return it->second;
  }
  std::optional<Info> try_find(const std::string& name) const {
    std::shared_lock lock(mutex_);
    const auto it = entries_.find(name);
    if (it == entries_.end()) return std::nullopt;
    return it->second;
  }

  // Calls the entry's factory with `args` (outside the lock, see the file comment). Only the factory
  // is copied: making an object does not copy the entry's other fields.
  template <class... Args>
  auto make(const std::string& name, Args&&... args) const {
    decltype(std::declval<const Info&>().make) factory;
    {
      std::shared_lock lock(mutex_);
      const auto it = entries_.find(name);
      if (it == entries_.end()) throw_invalid_message(unknown_message_locked(name));
      factory = it->second.make;
    }
    return factory(std::forward<Args>(args)...);
  }

  // Sorted by name.
  std::vector<std::string> names() const {
    std::shared_lock lock(mutex_);
    std::vector<std::string> out;
    out.reserve(entries_.size());
    for (const auto& [name, info] : entries_) out.push_back(name);
    return out;
  }
  std::vector<Info> all() const {
    std::shared_lock lock(mutex_);
    std::vector<Info> out;
    out.reserve(entries_.size());
    for (const auto& [name, info] : entries_) out.push_back(info);
    return out;
  }

  // The one message for an unknown name (what find/make throw), for callers that refuse a name
  // themselves.
  std::string unknown_message(const std::string& name) const {
    std::shared_lock lock(mutex_);
    return unknown_message_locked(name);
  }

 private:
  std::string unknown_message_locked(const std::string& name) const {
    std::string known;
    for (const auto& [key, info] : entries_) known += (known.empty() ? "" : ", ") + key;
    return "unknown " + kind_ + " '" + name + "'; known: " + (known.empty() ? "(none)" : known);
  }

  std::string kind_;
  mutable std::shared_mutex mutex_;
  std::map<std::string, Info> entries_;
};

}  // namespace glintlab
