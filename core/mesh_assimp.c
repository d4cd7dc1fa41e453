/* Mesh reading through assimp's C API: any format it reads (OBJ, PLY, OFF, ...),
 * triangulated, all meshes merged, vertices at identical positions welded (OBJ files
 * split vertices by normal or texture coordinate), with the appearance kept per triangle
 * corner (UVs of the first diffuse texture, vertex colours; core/mgs_mesh.h). Counts are checked against the file
 * size before assimp reads (mesh_check.c) and assimp validates what it read before its
 * other post-processing steps (aiProcess_ValidateDataStructure runs first); assimp runs in
 * a forked child under an address-space cap, so a crash inside it is an error message. */
#include <assimp/cimport.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <errno.h>
#include <signal.h>
#include <fcntl.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include "core/mesh_check.h"
#include "core/mgs_mesh.h"

typedef struct { float p[3]; uint32_t i; } keyed_vertex;
static int pos_cmp(const void *a, const void *b) {
  const float *p = ((const keyed_vertex *)a)->p, *q = ((const keyed_vertex *)b)->p;
  for (int k = 0; k < 3; k++)
    if (p[k] != q[k]) return p[k] < q[k] ? -1 : 1;
  return 0;
}

/* Merges vertices with identical positions; rewrites indices. */
static mgs_status weld(mgs_mesh *m) {
  if (m->nv < 2) return MGS_OK;
  keyed_vertex *kv = malloc(sizeof *kv * m->nv);
  uint32_t *remap = malloc(sizeof *remap * m->nv);
  float *nv = malloc(sizeof(float) * 3 * m->nv);
  if (!kv || !remap || !nv) { free(kv); free(remap); free(nv); return MGS_ERR_NOMEM; }
  for (size_t i = 0; i < m->nv; i++) {
    memcpy(kv[i].p, m->v + 3 * i, sizeof kv[i].p);
    kv[i].i = (uint32_t)i;
  }
  qsort(kv, m->nv, sizeof *kv, pos_cmp);
  size_t n = 0;
  for (size_t i = 0; i < m->nv; i++) {
    if (i == 0 || pos_cmp(&kv[i], &kv[i - 1]) != 0) {
      memcpy(nv + 3 * n, kv[i].p, sizeof(float) * 3);
      n++;
    }
    remap[kv[i].i] = (uint32_t)(n - 1);
  }
  for (size_t i = 0; i < m->nt * 3; i++) m->t[i] = remap[m->t[i]];
  free(m->v);
  m->v = nv;
  m->nv = n;
  free(kv);
  free(remap);
  return MGS_OK;
}

/* Some assimp readers repair bad input silently and only log it (the OFF reader clamps
 * out-of-range indices): such errors are caught from the log and made fatal. Errors
 * about other things (a missing .mtl file) stay harmless. */
static _Thread_local char log_error[256];
static void log_cb(const char *msg, char *user) {
  (void)user;
  if (log_error[0] || strncmp(msg, "Error", 5) != 0) return;
  if (strstr(msg, "out of range") || strstr(msg, "index") || strstr(msg, "Index")) {
    const char *m = strstr(msg, "T0: ");
    snprintf(log_error, sizeof log_error, "%s", m ? m + 4 : msg);
    size_t n = strlen(log_error);
    while (n && (log_error[n - 1] == '\n' || log_error[n - 1] == '\r')) log_error[--n] = 0;
  }
}

/* The diffuse texture of material `mi` (its first), or 0 when it has none. */
static int diffuse_texture(const struct aiScene *sc, unsigned mi, struct aiString *tex, unsigned *uv_channel) {
  if (mi >= sc->mNumMaterials) return 0;
  const struct aiMaterial *mat = sc->mMaterials[mi];
  if (aiGetMaterialTextureCount(mat, aiTextureType_DIFFUSE) == 0) return 0;
  unsigned uvi = 0;
  if (aiGetMaterialTexture(mat, aiTextureType_DIFFUSE, 0, tex, NULL, &uvi, NULL, NULL, NULL, NULL) != aiReturn_SUCCESS || tex->length == 0)
    return 0;
  *uv_channel = uvi < AI_MAX_NUMBER_OF_TEXTURECOORDS ? uvi : 0;
  return 1;
}

/* The texture file's path: relative ones against the mesh file's folder; Windows
   separators (common in exported .mtl files) become '/'. */
static char *resolve_texture(const char *mesh_path, const struct aiString *tex) {
  char rel[sizeof tex->data + 1];
  memcpy(rel, tex->data, tex->length);
  rel[tex->length] = 0;
  for (char *c = rel; *c; c++)
    if (*c == '\\') *c = '/';
  const char *r = rel;
  if (!strncmp(r, "file://", 7)) r += 7;
  while (r[0] == '.' && r[1] == '/') r += 2;
  const char *slash = strrchr(mesh_path, '/');
  size_t dn = (r[0] == '/' || !slash) ? 0 : (size_t)(slash - mesh_path) + 1;
  char *out = malloc(dn + strlen(r) + 1);
  if (!out) return NULL;
  memcpy(out, mesh_path, dn);
  strcpy(out + dn, r);
  return out;
}

/* Per-corner UVs (of the chosen texture's materials) and colours; NaN where absent. */
static mgs_status import_appearance(const char *path, const struct aiScene *sc, mgs_mesh *m, mgs_error *err) {
  struct aiString chosen = {0}, tex;
  int have_tex = 0, have_rgb = 0;
  for (unsigned i = 0; i < sc->mNumMeshes; i++) {
    const struct aiMesh *am = sc->mMeshes[i];
    unsigned ch = 0;
    if (!have_tex && diffuse_texture(sc, am->mMaterialIndex, &tex, &ch) && am->mTextureCoords[ch]) { chosen = tex; have_tex = 1; }
    if (am->mColors[0]) have_rgb = 1;
  }
  if (have_tex && !(m->uv = malloc(sizeof(float) * 6 * m->nt))) return mgs_error_set(err, MGS_ERR_NOMEM, "%s: out of memory", path);
  if (have_rgb && !(m->rgb = malloc(sizeof(float) * 9 * m->nt))) return mgs_error_set(err, MGS_ERR_NOMEM, "%s: out of memory", path);
  if (have_tex && !(m->texture = resolve_texture(path, &chosen))) return mgs_error_set(err, MGS_ERR_NOMEM, "%s: out of memory", path);
  size_t to = 0;
  for (unsigned i = 0; i < sc->mNumMeshes; i++) {
    const struct aiMesh *am = sc->mMeshes[i];
    unsigned ch = 0;
    const int uses = have_tex && diffuse_texture(sc, am->mMaterialIndex, &tex, &ch) && tex.length == chosen.length &&
                     !memcmp(tex.data, chosen.data, tex.length) && am->mTextureCoords[ch];
    for (unsigned f = 0; f < am->mNumFaces; f++) {
      const struct aiFace *fc = &am->mFaces[f];
      if (fc->mNumIndices != 3) continue; /* as the geometry */
      for (int k = 0; k < 3; k++) {
        const unsigned vi = fc->mIndices[k];
        if (m->uv) {
          float *uv = m->uv + 6 * to + 2 * k;
          uv[0] = uses ? am->mTextureCoords[ch][vi].x : NAN;
          uv[1] = uses ? am->mTextureCoords[ch][vi].y : NAN;
          if (!isfinite(uv[0]) || !isfinite(uv[1])) uv[0] = uv[1] = NAN;
        }
        if (m->rgb) {
          float *c = m->rgb + 9 * to + 3 * k;
          const struct aiColor4D *col = am->mColors[0] ? &am->mColors[0][vi] : NULL;
          for (int j = 0; j < 3; j++) {
            float x = col ? (j == 0 ? col->r : j == 1 ? col->g : col->b) : NAN;
            c[j] = isfinite(x) ? (x < 0 ? 0 : x > 1 ? 1 : x) : NAN;
          }
        }
      }
      to++;
    }
  }
  return MGS_OK;
}

static mgs_status import_assimp(const char *path, mgs_mesh **out, mgs_error *err) {
  *out = NULL;
  log_error[0] = 0;
  struct aiLogStream stream = {log_cb, NULL};
  aiAttachLogStream(&stream);
  const struct aiScene *sc = aiImportFile(path, aiProcess_ValidateDataStructure | aiProcess_Triangulate | aiProcess_JoinIdenticalVertices);
  aiDetachLogStream(&stream);
  if (sc && log_error[0]) {
    aiReleaseImport(sc);
    return mgs_error_set(err, MGS_ERR_FORMAT, "%s: %s", path, log_error);
  }
  if (!sc) {
    const char *e = aiGetErrorString();
    return mgs_error_set(err, MGS_ERR_FORMAT, "%s: cannot read mesh: %s", path, e && e[0] ? e : "unknown error");
  }
  size_t nv = 0, nt = 0;
  for (unsigned i = 0; i < sc->mNumMeshes; i++) {
    const struct aiMesh *am = sc->mMeshes[i];
    nv += am->mNumVertices;
    for (unsigned f = 0; f < am->mNumFaces; f++) nt += am->mFaces[f].mNumIndices == 3;
  }
  if (nv == 0 || nt == 0 || nv > UINT32_MAX) {
    aiReleaseImport(sc);
    return mgs_error_set(err, MGS_ERR_FORMAT, "%s: empty mesh (no triangles)", path);
  }
  mgs_mesh *m = mgs_mesh_create(nv, nt);
  if (!m) {
    aiReleaseImport(sc);
    return mgs_error_set(err, MGS_ERR_NOMEM, "%s: out of memory", path);
  }
  size_t vo = 0, to = 0;
  mgs_status status = MGS_OK;
  for (unsigned i = 0; i < sc->mNumMeshes && status == MGS_OK; i++) {
    const struct aiMesh *am = sc->mMeshes[i];
    for (unsigned v = 0; v < am->mNumVertices; v++) {
      const struct aiVector3D p = am->mVertices[v];
      if (!isfinite(p.x) || !isfinite(p.y) || !isfinite(p.z)) {
        status = mgs_error_set(err, MGS_ERR_FORMAT, "%s: vertex %zu is not finite", path, vo + v);
        break;
      }
      m->v[(vo + v) * 3 + 0] = p.x;
      m->v[(vo + v) * 3 + 1] = p.y;
      m->v[(vo + v) * 3 + 2] = p.z;
    }
    for (unsigned f = 0; f < am->mNumFaces && status == MGS_OK; f++) {
      const struct aiFace *fc = &am->mFaces[f];
      if (fc->mNumIndices != 3) continue; /* points and lines */
      for (int k = 0; k < 3; k++) {
        if (fc->mIndices[k] >= am->mNumVertices) {
          status = mgs_error_set(err, MGS_ERR_FORMAT, "%s: face %u refers to vertex %u of %u", path, f, fc->mIndices[k], am->mNumVertices);
          break;
        }
        m->t[to * 3 + (size_t)k] = (uint32_t)(vo + fc->mIndices[k]);
      }
      to++;
    }
    vo += am->mNumVertices;
  }
  if (status == MGS_OK) status = import_appearance(path, sc, m, err);
  aiReleaseImport(sc);
  if (status != MGS_OK) {
    mgs_mesh_destroy(m);
    return status;
  }
  *out = m;
  return MGS_OK;
}

static int write_all(int fd, const void *p, size_t n) {
  const char *c = p;
  while (n) {
    ssize_t w = write(fd, c, n);
    if (w < 0 && errno == EINTR) continue;
    if (w <= 0) return 0;
    c += w;
    n -= (size_t)w;
  }
  return 1;
}

static int read_all(int fd, void *p, size_t n) {
  char *c = p;
  while (n) {
    ssize_t r = read(fd, c, n);
    if (r < 0 && errno == EINTR) continue;
    if (r <= 0) return 0;
    c += r;
    n -= (size_t)r;
  }
  return 1;
}

/* The child: assimp on the file under an address-space cap; sends back
 * status (int32), then the message (256 bytes) or nv, nt (u64), the arrays, a flags byte
 * (1: uv, 2: rgb follow) with those arrays, and the texture path's length (u32, 0 = none)
 * and bytes. */
/* Present when built with a sanitizer (weak: null otherwise). */
extern void __sanitizer_set_death_callback(void (*)(void)) __attribute__((weak));

_Noreturn static void child_import(int fd, const char *path, size_t file_bytes) {
  /* relative to the address space at fork, so it also holds under ASan */
  FILE *f = fopen("/proc/self/statm", "r");
  unsigned long pages = 0;
  if (f) { if (fscanf(f, "%lu", &pages) != 1) pages = 0; fclose(f); }
  struct rlimit rl;
  rl.rlim_cur = rl.rlim_max = (rlim_t)pages * (rlim_t)sysconf(_SC_PAGESIZE) + (rlim_t)64 * file_bytes + ((rlim_t)1 << 30);
  setrlimit(RLIMIT_AS, &rl);
  /* glibc's heap-corruption reports would add lines to the one-line error */
  const int devnull = open("/dev/null", O_WRONLY);
  if (devnull >= 0) dup2(devnull, 2);
  /* a crash here is reported by the parent: default dispositions, no sanitizer death
     callback (libFuzzer's would record the contained crash as the parent's finding) */
  const int sigs[5] = {SIGSEGV, SIGBUS, SIGABRT, SIGFPE, SIGILL};
  for (int i = 0; i < 5; i++) signal(sigs[i], SIG_DFL);
  if (__sanitizer_set_death_callback) __sanitizer_set_death_callback(NULL);
  mgs_error err = {0};
  mgs_mesh *m = NULL;
  int32_t st = (int32_t)import_assimp(path, &m, &err);
  int ok = write_all(fd, &st, sizeof st);
  if (st != MGS_OK) {
    ok = ok && write_all(fd, err.msg, sizeof err.msg);
  } else {
    uint64_t nv = m->nv, nt = m->nt;
    ok = ok && write_all(fd, &nv, 8) && write_all(fd, &nt, 8) && write_all(fd, m->v, sizeof(float) * 3 * m->nv) &&
         write_all(fd, m->t, sizeof(uint32_t) * 3 * m->nt);
    const uint8_t flags = (uint8_t)((m->uv ? 1 : 0) | (m->rgb ? 2 : 0));
    const uint32_t tl = m->texture ? (uint32_t)strlen(m->texture) : 0;
    ok = ok && write_all(fd, &flags, 1) && (!m->uv || write_all(fd, m->uv, sizeof(float) * 6 * m->nt)) &&
         (!m->rgb || write_all(fd, m->rgb, sizeof(float) * 9 * m->nt)) && write_all(fd, &tl, 4) &&
         (!tl || write_all(fd, m->texture, tl));
  }
  _exit(ok ? 0 : 3);
}

/* The child's appearance arrays (see child_import); 0 when the pipe ends early. */
static int read_appearance(int fd, mgs_mesh *m, mgs_status *status, const char *path, mgs_error *err) {
  uint8_t flags = 0;
  uint32_t tl = 0;
  if (!read_all(fd, &flags, 1) || flags > 3) return 0;
  if ((flags & 1) && !(m->uv = malloc(sizeof(float) * 6 * m->nt))) { *status = mgs_error_set(err, MGS_ERR_NOMEM, "%s: out of memory", path); return 1; }
  if ((flags & 2) && !(m->rgb = malloc(sizeof(float) * 9 * m->nt))) { *status = mgs_error_set(err, MGS_ERR_NOMEM, "%s: out of memory", path); return 1; }
  if ((m->uv && !read_all(fd, m->uv, sizeof(float) * 6 * m->nt)) || (m->rgb && !read_all(fd, m->rgb, sizeof(float) * 9 * m->nt)) ||
      !read_all(fd, &tl, 4) || tl > 4096)
    return 0;
  if (tl) {
    if (!(m->texture = malloc((size_t)tl + 1))) { *status = mgs_error_set(err, MGS_ERR_NOMEM, "%s: out of memory", path); return 1; }
    if (!read_all(fd, m->texture, tl)) return 0;
    m->texture[tl] = 0;
  }
  return 1;
}

mgs_status mgs_mesh_read(const char *path, mgs_mesh **out, mgs_error *err) {
  *out = NULL;
  struct stat st;
  if (stat(path, &st) != 0) return mgs_error_set(err, MGS_ERR_IO, "%s: mesh file not found", path);
  if (!S_ISREG(st.st_mode)) return mgs_error_set(err, MGS_ERR_IO, "%s: not a regular file", path);
  /* Counts against the file size first: assimp trusts them (mesh_check.h). */
  mgs_status pre = mgs_mesh_precheck(path, err);
  if (pre != MGS_OK) return pre;
  /* Assimp itself runs in a forked child with an address-space cap: a crash or runaway
   * allocation inside it on a file the checks above let through is this reader's error
   * message, not the caller's crash. The child sends the merged arrays back. */
  int fds[2];
  if (pipe(fds) != 0) return mgs_error_set(err, MGS_ERR_IO, "%s: cannot create a pipe: %s", path, strerror(errno));
  fflush(NULL);
  pid_t pid = fork();
  if (pid < 0) {
    close(fds[0]); close(fds[1]);
    return mgs_error_set(err, MGS_ERR_IO, "%s: cannot fork the mesh reader: %s", path, strerror(errno));
  }
  if (pid == 0) {
    close(fds[0]);
    child_import(fds[1], path, (size_t)st.st_size);
  }
  close(fds[1]);
  int32_t cst = -1;
  mgs_status status = MGS_OK;
  mgs_mesh *m = NULL;
  int got = read_all(fds[0], &cst, sizeof cst);
  if (got && cst != MGS_OK) {
    char msg[sizeof err->msg];
    if (read_all(fds[0], msg, sizeof msg)) {
      msg[sizeof msg - 1] = 0;
      status = mgs_error_set(err, (mgs_status)cst, "%s", msg);
    } else {
      got = 0;
    }
  } else if (got) {
    uint64_t nv = 0, nt = 0;
    got = read_all(fds[0], &nv, 8) && read_all(fds[0], &nt, 8) && nv > 0 && nt > 0 && nv <= UINT32_MAX &&
          nv <= (uint64_t)st.st_size && nt <= (uint64_t)st.st_size * 3; /* each needs bytes in the file */
    if (got) m = mgs_mesh_create((size_t)nv, (size_t)nt);
    if (got && !m) status = mgs_error_set(err, MGS_ERR_NOMEM, "%s: out of memory", path);
    else if (got) got = read_all(fds[0], m->v, sizeof(float) * 3 * m->nv) && read_all(fds[0], m->t, sizeof(uint32_t) * 3 * m->nt);
    if (got && status == MGS_OK) got = read_appearance(fds[0], m, &status, path, err);
  }
  close(fds[0]);
  int ws = 0;
  while (waitpid(pid, &ws, 0) < 0 && errno == EINTR) {
  }
  if (status == MGS_OK && (!got || !WIFEXITED(ws) || WEXITSTATUS(ws) != 0)) {
    if (WIFSIGNALED(ws))
      status = mgs_error_set(err, MGS_ERR_FORMAT, "%s: cannot read mesh: the importer (assimp) failed on it with signal %d (corrupt file?)",
                             path, WTERMSIG(ws));
    else
      status = mgs_error_set(err, MGS_ERR_FORMAT, "%s: cannot read mesh: the importer (assimp) stopped (corrupt or too large)", path);
  }
  if (status == MGS_OK) {
    for (size_t i = 0; i < m->nt * 3; i++)
      if (m->t[i] >= m->nv) { status = mgs_error_set(err, MGS_ERR_FORMAT, "%s: triangle %zu has an index out of range", path, i / 3); break; }
  }
  if (status == MGS_OK && weld(m) != MGS_OK) status = mgs_error_set(err, MGS_ERR_NOMEM, "%s: out of memory", path);
  if (status != MGS_OK) {
    mgs_mesh_destroy(m);
    return status;
  }
  *out = m;
  return MGS_OK;
}
