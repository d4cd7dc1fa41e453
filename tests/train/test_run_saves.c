/* RUN/saves.csv: the training seconds at each saved model, kept across a kill and a
 * --resume (the experiment's wall time at an evaluation point reads it). */
#include <math.h>
#include "mgs_test.h"
#include "core/mgs_fs.h"
#include "train/mgs_train.h"

int main(void) {
  const char *dir = mgs_test_tmpdir("run_saves");
  mgs_error err;
  CHECK(isnan(mgs_run_saved_seconds(dir, 100))); /* no file */
  CHECK(mgs_run_record_save(dir, 100, 1.5, 1000, 1.25, &err) == MGS_OK);
  CHECK(mgs_run_record_save(dir, 200, 3.25, 1200, 3.0, &err) == MGS_OK);
  /* a resumed run saves 200 again (it continued from a checkpoint before it): the last wins */
  CHECK(mgs_run_record_save(dir, 200, 3.75, 1250, 3.5, &err) == MGS_OK);
  CHECK(mgs_run_saved_seconds(dir, 100) == 1.5);
  CHECK(mgs_run_saved_seconds(dir, 200) == 3.75);
  CHECK(isnan(mgs_run_saved_seconds(dir, 300)));
  char *p = mgs_path_join(dir, "saves.csv"), *text = NULL;
  size_t n = 0;
  CHECK(mgs_read_file(p, &text, &n, NULL) == MGS_OK);
  CHECK_MSG(text && !strcmp(text, "iteration,train_seconds,gaussians,train_cpu_seconds\n100,1.500000,1000,1.250000\n200,3.250000,1200,3.000000\n"
                    "200,3.750000,1250,3.500000\n"),
            "saves.csv: %s", text ? text : "(none)");
  free(text);
  free(p);
  /* a folder that cannot be written: an error naming the file, nothing else */
  CHECK(mgs_run_record_save("/proc/no-such-run", 1, 1.0, 1, 1.0, &err) != MGS_OK);
  CHECK_MSG(strstr(err.msg, "saves.csv") != NULL, "error: %s", err.msg);
  return mgs_test_finish();
}
