// Run-time loading of counting laws from plugin shared libraries (ABI: glintlab/plugin.h).
//
// load_plugin opens the library, validates its whole table before registering anything, then
// registers each entry with glintlab::register_law, so that make_law(name) and every driver,
// metric and report treat it like a built-in law. The library is never closed (registered laws
// call into its code). Loading a file that is already loaded returns its names and does nothing
// else; a changed file is not reloaded within a process.
#pragma once

#include <string>
#include <vector>

namespace glintlab {

// Loads the plugin at `path` (relative paths are taken from the current directory; no library
// search path) and returns the names of its laws, in table order. `reserved` are names taken
// elsewhere (the Python layer passes its custom laws' names) that an entry must not use.
// Throws std::invalid_argument naming the path and the problem: file missing, dlopen's own
// message, missing entry point, or a bad table entry (index, name and field).
std::vector<std::string> load_plugin(const std::string& path, const std::vector<std::string>& reserved = {});

struct LoadedPlugin {
  std::string path;  // canonical path of the library
  std::vector<std::string> laws;
};
// Plugins loaded so far in this process, in load order.
std::vector<LoadedPlugin> loaded_plugins();

}  // namespace glintlab
