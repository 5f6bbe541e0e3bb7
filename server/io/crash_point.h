#pragma once
// Fault injection for the crash tests: with TEXTOND_CRASH_POINT=<name> in its
// environment the process ends at once (_exit(86): no destructor, no flush, like kill -9) when it
// reaches that point of the write path, with one line on descriptor 2, "textond: crash point
// <name>", as a process dying of an uncaught exception or a failed check writes one. The points:
//   <ext>-written   write_file_atomic: the temporary is written and fsynced, not yet renamed
//   <ext>-renamed   write_file_atomic: renamed, its directory not yet fsynced
//   texton-synced   TextonDirectory::write: the texton's directory fsynced, not yet indexed
// where <ext> is the file's extension without the dot ("exr", "png", "json").
#include <string_view>

namespace textond::io {

void crash_point(std::string_view name);

} // namespace textond::io
