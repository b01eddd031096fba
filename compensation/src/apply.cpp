// circcomp apply and revert: the plan's files written and restored inside the configuration
// directory only (ConfigDir), with the originals and the manifest (manifest.hpp) in .circcomp/.
#include <fcntl.h>
#include <fmt/format.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstring>
#include <filesystem>
#include <map>
#include <set>

#include "circtest/compensation/config_dir.hpp"
#include "circtest/compensation/manifest.hpp"
#include "circtest/compensation/plan.hpp"
#include "circtest/core/error.hpp"
#include "circtest/core/sha256.hpp"

namespace circtest::compensation {

namespace fs = std::filesystem;

namespace {

constexpr const char* kState = ".circcomp";

std::string in_state(const std::string& file) {
  return std::string(kState) + "/" + file;
}

// Under the lock: the configuration is still what PLAN read (its INI's SHA-256, every file's
// text), or the plan is refused: another apply (or an editor) came first.
void require_unchanged(const ConfigDir& dir, const Plan& plan) {
  const auto ini = read_config_file(plan.ini_path);
  if (!plan.ini_sha256.empty() && (!ini || sha256_hex(*ini) != plan.ini_sha256)) {
    throw StaleError(fmt::format(
        "{} changed since this plan read it (another circcomp apply, or an editor): nothing "
        "changed; plan again",
        plan.ini_path));
  }
  for (const FileChange& f : plan.files) {
    const auto now = dir.read(f.name);
    if (now.has_value() != f.existed || (now && *now != f.before)) {
      throw StaleError(fmt::format(
          "{} changed since this plan read it (another circcomp apply, or an editor): nothing "
          "changed; plan again",
          f.path));
    }
  }
}

// Writes NAME through a temporary, calling AFTER_STEP when it is written and when in place.
class StepWriter {
 public:
  StepWriter(const ConfigDir& dir, const StepHook& hook) : dir_(dir), hook_(hook) {}
  void write(const std::string& name, const std::string& text, const std::string& what) {
    const auto out = dir_.output(name);
    out->write(text);
    step(what + ": written, not yet in place");
    out->commit();
    step(what + ": in place");
  }
  void step(const std::string& what) {
    if (hook_) hook_(step_, what);
    ++step_;
  }

 private:
  const ConfigDir& dir_;
  const StepHook& hook_;
  std::size_t step_ = 0;
};

// Removes the regular *.orig files of the state folder that KEEP does not name (originals of
// earlier or crashed applies); anything else there is left alone.
void sweep_originals(const ConfigDir& dir, const std::set<std::string>& keep) {
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(dir.path(kState), ec)) {
    const std::string name = entry.path().filename().string();
    if (!name.ends_with(".orig") || keep.count(name)) continue;
    std::error_code kind_ec;
    if (!entry.is_symlink(kind_ec) && entry.is_regular_file(kind_ec)) dir.remove(in_state(name));
  }
}

std::set<std::string> originals_of(const Manifest& m) {
  std::set<std::string> names;
  for (const auto* layer : {&m.last, &m.found}) {
    for (const ManifestEntry& e : *layer) {
      if (e.existed) names.insert(e.original);
    }
  }
  return names;
}

// The manifest now in the state folder, if any.
std::optional<Manifest> current_manifest(const ConfigDir& dir) {
  if (!dir.state_folder(kState, false)) return std::nullopt;
  const std::string name = in_state("manifest");
  const auto text = dir.read(name);
  if (!text) return std::nullopt;
  return parse_manifest(*text, dir.path(name), dir);
}

// One file a revert restores or removes, checked before any is touched.
struct RevertStep {
  const ManifestEntry* entry = nullptr;
  std::optional<std::string> original;  // the content to restore; nullopt: remove
  bool already = false;                 // the file is already in that state
};

RevertStep checked_step(const ConfigDir& dir, const ManifestEntry& e, bool force) {
  RevertStep s{&e, std::nullopt, false};
  if (e.existed) {
    s.original = dir.read(in_state(e.original));
    if (!s.original) {
      throw DataError(
          dir.path(in_state("manifest")), 0,
          fmt::format("the original of {} ({}) is missing: cannot restore it", e.name, e.original));
    }
  }
  const auto now = dir.read(e.name);
  s.already = now == s.original;
  const bool as_written = e.sha256.empty() || (now && sha256_hex(*now) == e.sha256);
  if (!s.already && !as_written && !force) {
    throw StaleError(fmt::format(
        "{}: {} since circcomp wrote it (SHA-256 {} written, {} now): nothing reverted; keep "
        "the change and undo circcomp's part by hand, or revert with --force to overwrite it",
        dir.path(e.name), now ? "changed" : "removed", e.sha256.substr(0, 12),
        now ? sha256_hex(*now).substr(0, 12) : std::string("none")));
  }
  return s;
}

// The "found" layer after the last apply is undone: entries whose file is back as found go,
// the others get the checksum of what is there now.
std::vector<ManifestEntry> found_after_undo(const ConfigDir& dir, const Manifest& m,
                                            const std::vector<RevertStep>& steps) {
  std::map<std::string, const RevertStep*> undone;
  for (const RevertStep& s : steps) undone[s.entry->name] = &s;
  std::vector<ManifestEntry> out;
  for (const ManifestEntry& f : m.found) {
    const auto it = undone.find(f.name);
    if (it == undone.end()) {
      out.push_back(f);
      continue;
    }
    const std::optional<std::string>& now = it->second->original;
    const std::optional<std::string> found =
        f.existed ? dir.read(in_state(f.original)) : std::nullopt;
    if (now == found) continue;
    ManifestEntry kept = f;
    kept.sha256 = sha256_hex(now.value_or(""));
    out.push_back(kept);
  }
  return out;
}

// The configurations this process holds the lock of, with the number of holders.
std::map<std::string, int>& held_locks() {
  static std::map<std::string, int> held;
  return held;
}

}  // namespace

ConfigLock::ConfigLock(const std::string& ini_path) {
  const ConfigDir dir(ini_path);
  root_ = dir.root();
  if (held_locks()[root_]++ > 0) return;  // held by an outer one of this process
  try {
    path_ = dir.path(in_state("lock"));
    for (int attempt = 0; attempt < 16 && fd_ < 0; ++attempt) {
      // The holder before removes the state folder when it is done and nothing else is in it.
      dir.state_folder(kState, true);
      const int fd = ::open(path_.c_str(), O_RDWR | O_CREAT | O_NOFOLLOW | O_CLOEXEC, 0644);
      if (fd < 0 && errno == ENOENT) continue;
      if (fd < 0) {
        throw IoError(path_, fmt::format("cannot open the lock: {}", std::strerror(errno)));
      }
      if (::flock(fd, LOCK_EX | LOCK_NB) != 0) {
        ::close(fd);
        throw StaleError(fmt::format(
            "{}: another circcomp apply or revert of this configuration is under way: nothing "
            "changed; when it is done, plan again",
            path_));
      }
      // The holder before removes the file when it is done: a lock on a removed file is no
      // lock, so it is opened again.
      struct stat held {};
      struct stat named {};
      if (::fstat(fd, &held) == 0 && ::lstat(path_.c_str(), &named) == 0 &&
          held.st_dev == named.st_dev && held.st_ino == named.st_ino) {
        fd_ = fd;
      } else {
        ::close(fd);
      }
    }
    if (fd_ < 0) throw IoError(path_, "the lock file keeps being replaced");
  } catch (...) {
    --held_locks()[root_];
    throw;
  }
}

ConfigLock::~ConfigLock() {
  if (--held_locks()[root_] > 0 || fd_ < 0) return;
  // Still held: the file goes, and the state folder with it when nothing else is in it.
  ::unlink(path_.c_str());
  ::rmdir(fs::path(path_).parent_path().c_str());
  ::close(fd_);
}

void apply_plan(const Plan& plan, const StepHook& after_step) {
  const ConfigDir dir(plan.ini_path);
  for (const FileChange& f : plan.files) dir.regular_or_absent(f.name);
  const ConfigLock lock(plan.ini_path);
  require_unchanged(dir, plan);
  const std::optional<Manifest> previous = current_manifest(dir);
  StepWriter writer(dir, after_step);
  const std::string prefix = fmt::format(
      "{:x}-{:x}", std::chrono::steady_clock::now().time_since_epoch().count(), ::getpid());
  Manifest next;
  if (previous) next.found = previous->found;
  for (ManifestEntry& f : next.found) {
    // A version-1 manifest has no checksums: what is there now is what its apply wrote.
    if (f.sha256.empty()) f.sha256 = sha256_hex(dir.read(f.name).value_or(""));
  }
  for (std::size_t i = 0; i < plan.files.size(); ++i) {
    const FileChange& f = plan.files[i];
    ManifestEntry e{f.name, f.existed, "", sha256_hex(f.after)};
    if (f.existed) {
      e.original = fmt::format("{}-{}.orig", prefix, i);
      writer.write(in_state(e.original), f.before, "original of " + f.path);
    }
    next.last.push_back(e);
    bool known = false;
    for (ManifestEntry& found : next.found) {
      if (found.name != f.name) continue;
      found.sha256 = e.sha256;
      known = true;
    }
    if (!known) next.found.push_back(e);
  }
  // The manifest is the commit point: killed before it is in place, the previous one still
  // names its own originals and nothing of the configuration has changed.
  writer.write(in_state("manifest"), render_manifest(next), "manifest");
  sweep_originals(dir, originals_of(next));
  for (const FileChange& f : plan.files) writer.write(f.name, f.after, f.path);
}

RevertResult revert(const std::string& ini_path, const RevertOptions& options,
                    const StepHook& after_step) {
  const ConfigDir dir(ini_path);
  RevertResult result;
  if (!dir.state_folder(kState, false)) return result;
  const ConfigLock lock(ini_path);
  const std::optional<Manifest> m = current_manifest(dir);
  if (!m || (m->last.empty() && m->found.empty())) {
    if (dir.state_folder(kState, false)) {
      // Originals of an apply killed before its manifest was in place: it changed nothing.
      sweep_originals(dir, {});
      if (m) dir.remove(in_state("manifest"));
      std::error_code ec;
      fs::remove(dir.path(kState), ec);  // only when empty
    }
    return result;
  }
  const std::vector<ManifestEntry>& entries = options.as_found ? m->found : m->last;
  if (entries.empty()) {
    result.earlier_kept = true;
    return result;
  }
  std::vector<RevertStep> steps;
  for (const ManifestEntry& e : entries) steps.push_back(checked_step(dir, e, options.force));
  StepWriter writer(dir, after_step);
  for (const RevertStep& s : steps) {
    if (!s.already) {
      if (s.original) {
        const auto out = dir.output(s.entry->name);
        out->write(*s.original);
        out->commit();
      } else {
        dir.remove(s.entry->name);
      }
    }
    writer.step(dir.path(s.entry->name) + (s.original ? ": restored" : ": removed"));
  }
  Manifest rest;
  if (!options.as_found) rest.found = found_after_undo(dir, *m, steps);
  // The manifest changes last: a revert killed before this point is done again by the next.
  if (rest.found.empty()) {
    dir.remove(in_state("manifest"));
    writer.step("manifest removed");
    sweep_originals(dir, {});
    std::error_code ec;
    fs::remove(dir.path(kState), ec);
  } else {
    const auto out = dir.output(in_state("manifest"));
    out->write(render_manifest(rest));
    out->commit();
    writer.step("manifest rewritten: the earlier applies remain");
    sweep_originals(dir, originals_of(rest));
    result.earlier_kept = true;
  }
  result.reverted = true;
  return result;
}

bool revert(const std::string& ini_path, const StepHook& after_step) {
  return revert(ini_path, RevertOptions{}, after_step).reverted;
}

}  // namespace circtest::compensation
