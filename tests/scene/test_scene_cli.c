/* `morsegs scene` through the CLI (MGS_CLI): builtins and mesh files, the exit codes
 * (0 ok, 1 runtime error, 2 usage), one-line errors naming the folder or file, and no
 * partial output on failure. */
#include <dirent.h>
#include <unistd.h>
#include <string.h>
#include "mgs_test.h"
#include "scene_test_util.h"
#include "core/mgs_fs.h"

static const char *cli;
static char root[1024], cmd[20000], log_path[1200];

static int run(const char *args) {
  snprintf(cmd, sizeof cmd, "'%s' %s", cli, args);
  return run_cmd(cmd, log_path);
}

static int hidden_entries(const char *dir) {
  DIR *d = opendir(dir);
  if (!d) return -1;
  int n = 0;
  struct dirent *e;
  while ((e = readdir(d)))
    if (e->d_name[0] == '.' && strcmp(e->d_name, ".") && strcmp(e->d_name, "..")) n++;
  closedir(d);
  return n;
}

static void write_text(const char *path, const char *text) {
  mgs_error err;
  CHECK_OK(mgs_write_file_atomic(path, text, strlen(text), &err), &err);
}

#define SMALL "--views 3 --test-views 1 --width 32 --height 24 --init-points 200 -q"

static void test_builtin_and_force(void) {
  char args[16384], p[2048];
  CHECK(run("scene --list") == 0);
  CHECK(file_contains(log_path, "genus2") && file_contains(log_path, "thin") && file_contains(log_path, "sphere"));
  CHECK(run("scene --help") == 0);
  snprintf(args, sizeof args, "scene --builtin thin -o '%s/ds' " SMALL " --specular --hemisphere --black --seed 5", root);
  CHECK(run(args) == 0);
  const char *files[] = {"transforms_train.json", "transforms_test.json", "train/r_2.png", "test/r_0.png", "gt_mesh.ply",
                         "points3d.ply", "scene.json"};
  for (size_t i = 0; i < sizeof files / sizeof files[0]; i++) {
    snprintf(p, sizeof p, "%s/ds/%s", root, files[i]);
    CHECK_MSG(mgs_path_exists(p), "missing %s", p);
  }
  snprintf(p, sizeof p, "%s/ds/scene.json", root);
  CHECK(file_contains(p, "\"black\"") && file_contains(p, "builtin:thin"));
  /* Again without --force: refused, naming the folder; nothing changed or left behind. */
  CHECK(run(args) == 1);
  snprintf(p, sizeof p, "%s/ds", root);
  CHECK(file_contains(log_path, p) && file_contains(log_path, "--force"));
  CHECK(hidden_entries(root) == 0);
  snprintf(args, sizeof args, "scene --builtin thin -o '%s/ds' " SMALL " --init random --force", root);
  CHECK(run(args) == 0);
  CHECK(hidden_entries(root) == 0);
}

static void test_mesh_files(void) {
  char args[16384], p[2048], obj[2048];
  /* A closed tetrahedron as OBJ. */
  snprintf(obj, sizeof obj, "%s/tet.obj", root);
  write_text(obj, "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n");
  snprintf(args, sizeof args, "scene '%s' -o '%s/tet' " SMALL, obj, root);
  CHECK(run(args) == 0);
  snprintf(p, sizeof p, "%s/tet/gt_mesh.ply", root);
  CHECK(mgs_path_exists(p));
  /* An open mesh: one triangle. Error naming the file, unless --allow-open. */
  snprintf(obj, sizeof obj, "%s/tri.obj", root);
  write_text(obj, "v 0 0 0\nv 1 0 0\nv 0 1 0.3\nf 1 2 3\n");
  snprintf(args, sizeof args, "scene '%s' -o '%s/tri' " SMALL, obj, root);
  CHECK(run(args) == 1);
  CHECK(file_contains(log_path, "tri.obj") && file_contains(log_path, "--allow-open"));
  snprintf(p, sizeof p, "%s/tri", root);
  CHECK(!mgs_path_exists(p));
  snprintf(args, sizeof args, "scene '%s' -o '%s/tri' " SMALL " --allow-open", obj, root);
  CHECK(run(args) == 0);
  /* Missing and empty mesh files. */
  snprintf(args, sizeof args, "scene '%s/nope.obj' -o '%s/nope' " SMALL, root, root);
  CHECK(run(args) == 1);
  CHECK(file_contains(log_path, "nope.obj"));
  snprintf(obj, sizeof obj, "%s/empty.obj", root);
  write_text(obj, "# nothing\n");
  snprintf(args, sizeof args, "scene '%s' -o '%s/empty' " SMALL, obj, root);
  CHECK(run(args) == 1);
  CHECK(file_contains(log_path, "empty.obj"));
  snprintf(p, sizeof p, "%s/empty", root);
  CHECK(!mgs_path_exists(p));
  CHECK(hidden_entries(root) == 0);
}

static void test_usage_errors(void) {
  char args[16384];
  snprintf(args, sizeof args, "scene --builtin teapot -o '%s/x'", root);
  CHECK(run(args) == 2);
  CHECK(file_contains(log_path, "teapot"));
  CHECK(run("scene --builtin sphere") == 2);                      /* no -o */
  snprintf(args, sizeof args, "scene a.obj --builtin sphere -o '%s/x'", root);
  CHECK(run(args) == 2);                                          /* both */
  snprintf(args, sizeof args, "scene --builtin sphere -o '%s/x' --views zero", root);
  CHECK(run(args) == 2);
  snprintf(args, sizeof args, "scene --builtin sphere -o '%s/x' --init sfm", root);
  CHECK(run(args) == 2);
  snprintf(args, sizeof args, "scene --builtin sphere -o '%s/x' --bogus", root);
  CHECK(run(args) == 2);
  const char *scales[] = {"0", "-1", "nan", "inf", "1e9", "x"};
  for (int i = 0; i < 6; i++) {
    snprintf(args, sizeof args, "scene --builtin sphere -o '%s/x' --texture-scale %s", root, scales[i]);
    CHECK_MSG(run(args) == 2, "--texture-scale %s accepted", scales[i]);
    CHECK(file_contains(log_path, "--texture-scale"));
  }
  char p[2048];
  snprintf(p, sizeof p, "%s/x", root);
  CHECK(!mgs_path_exists(p));
}

int main(void) {
  cli = getenv("MGS_CLI");
  if (!cli) { fprintf(stderr, "MGS_CLI not set\n"); return 1; }
  char cwd[512];
  if (!getcwd(cwd, sizeof cwd)) return 1;
  snprintf(root, sizeof root, "%s/%s", cwd, mgs_test_tmpdir("scene_cli"));
  snprintf(log_path, sizeof log_path, "%s/log.txt", cwd);
  RUN(test_builtin_and_force);
  RUN(test_mesh_files);
  RUN(test_usage_errors);
  return mgs_test_finish();
}
