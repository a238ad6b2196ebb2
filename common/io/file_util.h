// Whole-file reads and atomic writes with errors that name the file.
//
// Every dome output goes through WriteFileAtomically (or TempSiblingPath +
// CommitTempFile for libraries that insist on writing a path themselves): the bytes
// are written to a temporary file in the destination folder and renamed over the
// destination, so a reader -- another worker, the master resuming from its journal --
// never sees a half-written file, and a job that is killed and re-run leaves the same
// result (SPEC "Nothing lost").
#pragma once

#include <filesystem>
#include <string>
#include <string_view>

namespace dome::io {

// The whole content of `path`. Throws core::InputError naming the file when it is
// missing, is a folder, or cannot be read (permissions, I/O error).
std::string ReadFileBytes(const std::filesystem::path& path);

// Throws core::InputError naming `path` unless the folder that would hold it exists
// and is a folder. Writability itself is found out by the write that follows.
void RequireParentFolder(const std::filesystem::path& path);

// Writes `bytes` to `path` atomically (temporary sibling + rename). Throws
// core::InputError naming the file when its folder is missing, core::StorageError
// naming the file with the system's reason when the write fails (read-only folder,
// disk full); no temporary file is left behind.
void WriteFileAtomically(const std::filesystem::path& path, std::string_view bytes);

// A fresh name in the folder of `path` for a temporary file ("<name>.tmp-<pid>-<n>").
std::filesystem::path TempSiblingPath(const std::filesystem::path& path);

// Removes the temporary files (TempSiblingPath's names) under `dir`, at any depth,
// whose writing process is gone: a process killed mid-write leaves its temporary file
// beside the file it never finished. Files of live processes are kept. Returns how
// many it removed; errors (a file gone meanwhile) are skipped.
int RemoveStaleTempFiles(const std::filesystem::path& dir);

// Renames the finished temporary `tmp` over `path`; removes `tmp` and throws
// core::StorageError naming `path` when that fails.
void CommitTempFile(const std::filesystem::path& tmp, const std::filesystem::path& path);

}  // namespace dome::io
