/* One trainer per run folder: an exclusive flock on RUN/.morsegs-train.lock, held for the
 * whole run. The kernel drops the lock when the process ends, however it ends (SIGKILL
 * included), so a killed trainer never blocks the next one; the file names the holder's
 * pid for the refusal message. Holding the lock also makes it safe to delete the temp
 * files that killed trainers left beside their atomic writes. */
#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include "core/mgs_fs.h"
#include "train/mgs_train.h"

#define LOCK_NAME ".morsegs-train.lock"

struct mgs_run_lock {
  int fd;
  char *path;
};

/* Removes "NAME.tmp-PID-N" files (mgs_temp_path_for) of other processes in `dir`. */
static void sweep_temps(const char *dir) {
  DIR *d = opendir(dir);
  if (!d) return;
  struct dirent *e;
  while ((e = readdir(d))) {
    const char *t = strstr(e->d_name, ".tmp-");
    long pid;
    unsigned n;
    char tail;
    if (!t || sscanf(t, ".tmp-%ld-%u%c", &pid, &n, &tail) != 2 || pid == (long)getpid()) continue;
    char *p = mgs_path_join(dir, e->d_name);
    if (p) remove(p);
    free(p);
  }
  closedir(d);
}

static void sweep_run(const char *run_dir) {
  sweep_temps(run_dir);
  char *pc = mgs_path_join(run_dir, "point_cloud");
  DIR *d = pc ? opendir(pc) : NULL;
  if (d) {
    struct dirent *e;
    while ((e = readdir(d))) {
      if (strncmp(e->d_name, "iteration_", 10) != 0) continue;
      char *sub = mgs_path_join(pc, e->d_name);
      if (sub) sweep_temps(sub);
      free(sub);
    }
    closedir(d);
  }
  free(pc);
}

mgs_status mgs_run_lock_acquire(const char *run_dir, mgs_run_lock **out, mgs_error *err) {
  *out = NULL;
  mgs_status st = mgs_mkdir_p(run_dir, err);
  if (st != MGS_OK) return st;
  char *path = mgs_path_join(run_dir, LOCK_NAME);
  if (!path) return mgs_error_set(err, MGS_ERR_NOMEM, "%s: out of memory", run_dir);
  for (int attempt = 0; attempt < 8; attempt++) {
    int fd = open(path, O_RDWR | O_CREAT | O_CLOEXEC, 0644);
    if (fd < 0) {
      int e = errno;
      free(path);
      return mgs_error_set(err, MGS_ERR_IO, "%s: cannot write in the run folder (%s)", run_dir, strerror(e));
    }
    if (flock(fd, LOCK_EX | LOCK_NB) != 0) {
      int e = errno;
      char buf[32] = {0};
      ssize_t n = pread(fd, buf, sizeof buf - 1, 0);
      close(fd);
      free(path);
      if (e == EWOULDBLOCK) {
        long pid = n > 0 ? strtol(buf, NULL, 10) : 0;
        if (pid > 0)
          return mgs_error_set(err, MGS_ERR_IO, "%s: another morsegs train (pid %ld) is using this run folder; wait for it to end or choose another -o", run_dir, pid);
        return mgs_error_set(err, MGS_ERR_IO, "%s: another morsegs train is using this run folder; wait for it to end or choose another -o", run_dir);
      }
      return mgs_error_set(err, MGS_ERR_IO, "%s: cannot lock the run folder (%s)", run_dir, strerror(e));
    }
    /* The previous holder unlinks the file on release: if it did so between our open and
     * our flock, we hold a lock on a file nobody else will see; try again. */
    struct stat a, b;
    if (fstat(fd, &a) != 0 || stat(path, &b) != 0 || a.st_ino != b.st_ino || a.st_dev != b.st_dev) {
      close(fd);
      continue;
    }
    char pid[32];
    int len = snprintf(pid, sizeof pid, "%ld\n", (long)getpid());
    if (ftruncate(fd, 0) != 0 || pwrite(fd, pid, (size_t)len, 0) != len) {
      int e = errno;
      close(fd);
      unlink(path);
      free(path);
      return mgs_error_set(err, MGS_ERR_IO, "%s: cannot write in the run folder (%s)", run_dir, strerror(e));
    }
    mgs_run_lock *l = malloc(sizeof *l);
    if (!l) { close(fd); unlink(path); free(path); return mgs_error_set(err, MGS_ERR_NOMEM, "%s: out of memory", run_dir); }
    l->fd = fd;
    l->path = path;
    sweep_run(run_dir);
    *out = l;
    return MGS_OK;
  }
  free(path);
  return mgs_error_set(err, MGS_ERR_IO, "%s: cannot lock the run folder (the lock file keeps changing)", run_dir);
}

void mgs_run_lock_release(mgs_run_lock *l) {
  if (!l) return;
  unlink(l->path); /* while still holding the lock: see the inode check above */
  close(l->fd);
  free(l->path);
  free(l);
}
