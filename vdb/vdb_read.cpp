// Validated .vdb reading (see vdb_read.hpp for why).
#include "vdb/vdb_read.hpp"

#include <openvdb/io/Stream.h>
#include <fcntl.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>
#include <cerrno>
#include <csignal>
#include <cstdio>
#include <cctype>
#include <cstring>
#include <istream>
#include <sstream>
#include <streambuf>

#include "vdb/vdb_internal.hpp"

// Present when built with a sanitizer (weak: null otherwise).
extern "C" void __sanitizer_set_death_callback(void (*)(void)) __attribute__((weak));

namespace mgs_vdb_detail {
namespace {

// A read-only streambuf over bytes in memory (seekable, so OpenVDB may ask tellg).
struct mem_buf : std::streambuf {
  mem_buf(const char *b, size_t n) {
    char *p = const_cast<char *>(b);
    setg(p, p, p + n);
  }
  pos_type seekoff(off_type off, std::ios_base::seekdir dir, std::ios_base::openmode) override {
    char *base = eback();
    off_type pos = dir == std::ios_base::beg ? off : dir == std::ios_base::cur ? (gptr() - base) + off : (egptr() - base) + off;
    if (pos < 0 || pos > egptr() - base) return pos_type(off_type(-1));
    setg(base, base + pos, egptr());
    return pos_type(pos);
  }
  pos_type seekpos(pos_type p, std::ios_base::openmode m) override { return seekoff(off_type(p), std::ios_base::beg, m); }
};

// Bounds-checked cursor over the file's bytes; fails with a message naming the field.
struct cursor {
  const unsigned char *d;
  size_t n, pos;
  const char *path;
  mgs_error *err;
  mgs_status st = MGS_OK;
  bool fail(const char *what) {
    if (st == MGS_OK)
      st = mgs_error_set(err, MGS_ERR_FORMAT, "%s: not a readable .vdb file (%s at byte %zu of %zu: truncated or corrupt)", path, what, pos, n);
    return false;
  }
  bool take(size_t k, const char *what) {
    if (st != MGS_OK) return false;
    if (k > n - pos) return fail(what);
    pos += k;
    return true;
  }
  template <class T> bool get(T *v, const char *what) {
    if (st != MGS_OK || sizeof(T) > n - pos) return fail(what);
    std::memcpy(v, d + pos, sizeof(T));  // OpenVDB writes native (little-endian) order
    pos += sizeof(T);
    return true;
  }
  bool str(std::string *s, const char *what) {
    uint32_t len = 0;
    if (!get(&len, what)) return false;
    if (len > n - pos) return fail(what);
    if (s) s->assign(reinterpret_cast<const char *>(d + pos), len);
    pos += len;
    return true;
  }
  // MetaMap: count, then (name, type name, byte count, bytes) per entry.
  // `cls` (may be null) receives the value of a string entry named "class".
  bool metamap(size_t limit, const char *what, std::string *cls = nullptr) {
    uint32_t count = 0;
    if (!get(&count, what)) return false;
    if (pos > limit || count > (limit - pos) / 12) return fail(what);  // each entry needs >= 12 bytes
    for (uint32_t i = 0; i < count; i++) {
      uint32_t bytes = 0;
      std::string name, type;
      if (!str(&name, what) || !str(&type, what) || !get(&bytes, what) || !take(bytes, what)) return false;
      if (cls && name == "class" && type == "string") cls->assign(reinterpret_cast<const char *>(d + pos - bytes), bytes);
    }
    return pos <= limit || fail(what);
  }
};

// OpenVDB names duplicate grids "name\x1e<n>"; the user sees the plain name.
std::string strip_suffix(const std::string &s) {
  const size_t k = s.find('\x1e');
  return k == std::string::npos ? s : s.substr(0, k);
}

mgs_status check_header(cursor &c, vdb_index *out) {
  int64_t magic = 0;
  uint32_t version = 0, lib_major = 0, lib_minor = 0;
  if (!c.get(&magic, "magic number")) return c.st;
  if (magic != openvdb::OPENVDB_MAGIC)
    return mgs_error_set(c.err, MGS_ERR_FORMAT, "%s: not a readable .vdb file (no VDB magic number)", c.path);
  if (!c.get(&version, "file version")) return c.st;
  if (version < openvdb::OPENVDB_FILE_VERSION_NODE_MASK_COMPRESSION || version > openvdb::OPENVDB_FILE_VERSION)
    return mgs_error_set(c.err, MGS_ERR_UNSUPPORTED, "%s: .vdb file format version %u is not supported (%u to %u are)", c.path,
                         version, (unsigned)openvdb::OPENVDB_FILE_VERSION_NODE_MASK_COMPRESSION, (unsigned)openvdb::OPENVDB_FILE_VERSION);
  char offsets = 0;
  if (!c.get(&lib_major, "library version") || !c.get(&lib_minor, "library version") || !c.get(&offsets, "header flags"))
    return c.st;
  if (!offsets)
    return mgs_error_set(c.err, MGS_ERR_UNSUPPORTED, "%s: .vdb written as a stream without grid offsets is not supported", c.path);
  if (!c.take(36, "UUID")) return c.st;
  for (size_t i = c.pos - 36; i < c.pos; i++)
    if (c.d[i] != '-' && !std::isxdigit(c.d[i])) return c.fail("UUID"), c.st;
  if (!c.metamap(c.n, "file metadata")) return c.st;
  out->count_pos = c.pos;
  int32_t ngrids = 0;
  if (!c.get(&ngrids, "grid count")) return c.st;
  if (ngrids < 0 || (size_t)ngrids > (c.n - c.pos) / 40) return c.fail("grid count"), c.st;
  for (int32_t g = 0; g < ngrids; g++) {
    std::string name, type, cls;
    const size_t desc_begin = c.pos;
    int64_t grid_pos = 0, block_pos = 0, end_pos = 0;
    if (!c.str(&name, "grid name") || !c.str(&type, "grid type") || !c.str(nullptr, "instance parent name") ||
        !c.get(&grid_pos, "grid offset") || !c.get(&block_pos, "grid offset") || !c.get(&end_pos, "grid offset"))
      return c.st;
    if (grid_pos != (int64_t)c.pos || block_pos < grid_pos || end_pos < block_pos || (uint64_t)end_pos > c.n)
      return mgs_error_set(c.err, MGS_ERR_FORMAT,
                           "%s: not a readable .vdb file (grid '%s' claims bytes %lld to %lld of a %zu-byte file: truncated or corrupt)",
                           c.path, strip_suffix(name).c_str(), (long long)grid_pos, (long long)end_pos, c.n);
    // The grid's own header: compression flags, metadata, transform (type name + map).
    uint32_t compression = 0;
    if (!c.get(&compression, "grid compression flags") || !c.metamap((size_t)block_pos, "grid metadata", &cls) ||
        !c.str(nullptr, "grid transform"))
      return c.st;
    if (c.pos > (size_t)block_pos) return c.fail("grid header"), c.st;
    out->names.push_back(strip_suffix(name));
    // Grids saved as half floats carry a suffix on their type; they read back as float.
    static const std::string half = "_HalfFloat";
    if (type.size() > half.size() && type.compare(type.size() - half.size(), half.size(), half) == 0)
      type.resize(type.size() - half.size());
    out->types.push_back(type);
    out->classes.push_back(cls);
    out->begin.push_back(desc_begin);
    out->end.push_back((size_t)end_pos);
    c.pos = (size_t)end_pos;
  }
  return MGS_OK;
}

}  // namespace

mgs_status check_vdb(const char *path, vdb_index *idx, mgs_error *err) {
  init();
  idx->path = path;
  struct stat sb;
  if (stat(path, &sb) != 0) return mgs_error_set(err, MGS_ERR_IO, "%s: no such file", path);
  if (S_ISDIR(sb.st_mode)) return mgs_error_set(err, MGS_ERR_IO, "%s: is a directory, not a .vdb file", path);
  std::FILE *f = std::fopen(path, "rb");
  if (!f) return mgs_error_set(err, MGS_ERR_IO, "%s: cannot open: %s", path, std::strerror(errno));
  try {
    idx->bytes.resize((size_t)sb.st_size);
  } catch (const std::exception &) {
    std::fclose(f);
    return mgs_error_set(err, MGS_ERR_NOMEM, "%s: out of memory for a %lld-byte file", path, (long long)sb.st_size);
  }
  const size_t got = idx->bytes.empty() ? 0 : std::fread(idx->bytes.data(), 1, idx->bytes.size(), f);
  std::fclose(f);
  if (got != idx->bytes.size()) return mgs_error_set(err, MGS_ERR_IO, "%s: read error", path);
  cursor c{reinterpret_cast<const unsigned char *>(idx->bytes.data()), idx->bytes.size(), 0, path, err};
  return check_header(c, idx);
}

std::string value_type_of(const std::string &tree_type) {
  // "Tree_vec3s_5_4_3" -> "vec3s" (what OpenVDB's valueType() says); others unchanged.
  if (tree_type.compare(0, 5, "Tree_") != 0) return tree_type;
  const size_t end = tree_type.find('_', 5);
  return tree_type.substr(5, end == std::string::npos ? std::string::npos : end - 5);
}

std::string grid_list(const vdb_index &idx) {
  std::string s;
  for (size_t i = 0; i < idx.names.size(); i++) s += (i ? ", " : "") + idx.names[i] + " (" + value_type_of(idx.types[i]) + ")";
  return s.empty() ? "none" : s;
}

namespace {
// Parses `b` with OpenVDB through a throwing stream; fills meta and grid (when asked).
// Throws what OpenVDB throws.
void parse_stream(const std::vector<char> &b, bool want_grid, openvdb::MetaMap::Ptr *meta, openvdb::GridBase::Ptr *grid) {
  mem_buf buf(b.data(), b.size());
  std::istream is(&buf);
  is.exceptions(std::ios_base::failbit | std::ios_base::badbit);
  openvdb::io::Stream s(is, /*delayLoad=*/false);
  *meta = s.getMetadata();
  if (want_grid) {
    openvdb::GridPtrVecPtr gs = s.getGrids();
    *grid = gs && !gs->empty() ? (*gs)[0] : nullptr;
  }
}

std::string describe(const std::exception &e) {
  if (dynamic_cast<const std::ios_base::failure *>(&e)) return "grid data ends early or is corrupt";
  if (dynamic_cast<const std::bad_alloc *>(&e)) return "a size in it is too large: corrupt";
  return e.what();
}

size_t vm_bytes() {
  std::FILE *f = std::fopen("/proc/self/statm", "r");
  unsigned long pages = 0;
  if (f) {
    if (std::fscanf(f, "%lu", &pages) != 1) pages = 0;
    std::fclose(f);
  }
  return (size_t)pages * (size_t)sysconf(_SC_PAGESIZE);
}

bool write_all(int fd, const char *p, size_t n) {
  while (n) {
    ssize_t w = write(fd, p, n);
    if (w < 0 && errno == EINTR) continue;
    if (w <= 0) return false;
    p += w;
    n -= (size_t)w;
  }
  return true;
}

// The child: parse the untrusted bytes under an address-space cap, then write what it
// read back with OpenVDB's writer (whose output is consistent by construction). Status
// byte 'O' + stream, or 'E' + message.
[[noreturn]] void child_main(int fd, const std::vector<char> &b, bool want_grid, size_t file_bytes) {
  // glibc's heap-corruption reports and OpenVDB's warnings would add lines to the
  // caller's one-line error: the parent says what happened.
  const int devnull = open("/dev/null", O_WRONLY);
  if (devnull >= 0) dup2(devnull, 2);
  // A crash here is reported by the parent: default dispositions, and no sanitizer death
  // callback (under libFuzzer, the fuzzer's handlers would record the contained crash as
  // a finding of the parent).
  for (int sig : {SIGSEGV, SIGBUS, SIGABRT, SIGFPE, SIGILL}) std::signal(sig, SIG_DFL);
  if (__sanitizer_set_death_callback) __sanitizer_set_death_callback(nullptr);
  // The cap is relative to the address space at fork, so it also holds under ASan (whose
  // shadow and allocator regions are reserved at start-up).
  struct rlimit rl;
  const rlim_t cap = (rlim_t)(vm_bytes() + 64 * file_bytes + ((size_t)512 << 20));
  rl.rlim_cur = rl.rlim_max = cap;
  setrlimit(RLIMIT_AS, &rl);
  std::string out;
  try {
    openvdb::MetaMap::Ptr meta;
    openvdb::GridBase::Ptr grid;
    parse_stream(b, want_grid, &meta, &grid);
    std::ostringstream os(std::ios_base::binary);
    openvdb::GridCPtrVec vec;
    if (grid) vec.push_back(grid);
    openvdb::io::Stream(os).write(vec, meta ? *meta : openvdb::MetaMap());
    out = "O" + os.str();
  } catch (const std::exception &e) {
    out = "E" + describe(e);
  } catch (...) {
    out = "Eunknown error";
  }
  _exit(write_all(fd, out.data(), out.size()) ? 0 : 3);
}
}  // namespace

mgs_status load_vdb(const vdb_index &idx, int which, openvdb::MetaMap::Ptr *meta, openvdb::GridBase::Ptr *grid,
                    mgs_error *err) {
  const char *path = idx.path.c_str();
  // The header and file metadata, a grid count, and the chosen grid's bytes: OpenVDB reads
  // only what was asked for.
  std::vector<char> b(idx.bytes.begin(), idx.bytes.begin() + (long)idx.count_pos);
  const int32_t one = which >= 0 ? 1 : 0;
  b.insert(b.end(), reinterpret_cast<const char *>(&one), reinterpret_cast<const char *>(&one) + 4);
  if (which >= 0) {
    // The descriptor's offsets are absolute; OpenVDB's stream reader does not use them.
    b.insert(b.end(), idx.bytes.begin() + (long)idx.begin[(size_t)which], idx.bytes.begin() + (long)idx.end[(size_t)which]);
  }
  // OpenVDB's reader can still write out of bounds on bytes that pass the header checks
  // (a raw chunk whose negative size is larger than its node: bloscFromStream copies before
  // it compares; found by fuzzing). So the untrusted bytes are parsed in a child process
  // with an address-space cap; the parent parses only what the child wrote back.
  int fds[2];
  if (pipe(fds) != 0) return mgs_error_set(err, MGS_ERR_IO, "%s: cannot create a pipe: %s", path, std::strerror(errno));
  std::fflush(nullptr);
  const pid_t pid = fork();
  if (pid < 0) {
    close(fds[0]);
    close(fds[1]);
    return mgs_error_set(err, MGS_ERR_IO, "%s: cannot fork the reader: %s", path, std::strerror(errno));
  }
  if (pid == 0) {
    close(fds[0]);
    child_main(fds[1], b, grid != nullptr, idx.bytes.size());
  }
  close(fds[1]);
  std::vector<char> reply;
  char chunk[1 << 16];
  for (;;) {
    ssize_t r = read(fds[0], chunk, sizeof chunk);
    if (r < 0 && errno == EINTR) continue;
    if (r <= 0) break;
    reply.insert(reply.end(), chunk, chunk + r);
  }
  close(fds[0]);
  int status = 0;
  while (waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  if (WIFSIGNALED(status))
    return mgs_error_set(err, MGS_ERR_FORMAT, "%s: not a readable .vdb file (OpenVDB's reader failed on it with signal %d: corrupt)",
                         path, WTERMSIG(status));
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0 || reply.empty())
    return mgs_error_set(err, MGS_ERR_FORMAT, "%s: not a readable .vdb file (the reader stopped: corrupt or too large)", path);
  if (reply[0] != 'O')
    return mgs_error_set(err, MGS_ERR_FORMAT, "%s: not a readable .vdb file (%s)", path, std::string(reply.begin() + 1, reply.end()).c_str());
  reply.erase(reply.begin());
  try {
    openvdb::MetaMap::Ptr m;
    openvdb::GridBase::Ptr g;
    parse_stream(reply, grid != nullptr, &m, &g);
    if (meta) *meta = m;
    if (grid) {
      *grid = g;
      if (!g) return mgs_error_set(err, MGS_ERR_FORMAT, "%s: not a readable .vdb file (grid missing)", path);
    }
  } catch (const std::exception &e) {
    return mgs_error_set(err, MGS_ERR_FORMAT, "%s: not a readable .vdb file (%s)", path, describe(e).c_str());
  }
  return MGS_OK;
}
}  // namespace mgs_vdb_detail
