/* Scratch directories of the unit tests.
 *
 * ej_test_tmpdir() makes a fresh directory $TMPDIR/ej_<tag>_XXXXXX ($TMPDIR defaults to /tmp) and
 * removes it, with everything under it, when the process that made it exits normally. Check runs
 * every test in a forked child: a test that passes ends with exit() and its directory goes with
 * it; a failed assertion ends the child with _exit(), so a failed test's scene and output stay
 * for inspection (the failure message names the test; the directory is the newest ej_<tag>_*).
 * A directory made in the parent (an unchecked fixture) goes when the suite ends. Before this
 * helper the suites left every run's scene and HDF5 output behind: about 9,400 directories and
 * 3 GB in /tmp on a development machine. */
#ifndef EJ_TEST_TMPDIR_H
#define EJ_TEST_TMPDIR_H

#include <check.h>
#include <dirent.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/types.h>
#include <unistd.h>

typedef struct {
  char path[256];
  pid_t pid;
} ej_test_tmpdir_entry_;

static ej_test_tmpdir_entry_ *ej_test_tmpdirs_;
static int ej_test_tmpdir_n_, ej_test_tmpdir_cap_;

/* Removes path and, when it is a directory, everything under it (symbolic links are removed,
 * not followed). */
static inline void ej_test_rmtree(const char *path)
{
  struct stat st;
  if (lstat(path, &st) != 0) return;
  if (S_ISDIR(st.st_mode)) {
    DIR *d = opendir(path);
    if (d) {
      struct dirent *e;
      while ((e = readdir(d)) != NULL) {
        if (!strcmp(e->d_name, ".") || !strcmp(e->d_name, "..")) continue;
        char child[1024];
        if (snprintf(child, sizeof child, "%s/%s", path, e->d_name) < (int)sizeof child) ej_test_rmtree(child);
      }
      closedir(d);
    }
    rmdir(path);
  } else {
    unlink(path);
  }
}

/* atexit handler: removes the directories this process made (a forked child inherits the
 * parent's list but not its directories). */
static inline void ej_test_tmpdir_cleanup_(void)
{
  pid_t me = getpid();
  for (int k = 0; k < ej_test_tmpdir_n_; k++)
    if (ej_test_tmpdirs_[k].pid == me) ej_test_rmtree(ej_test_tmpdirs_[k].path);
}

/* Makes the directory into dir (n bytes) and registers it for removal at exit. */
static inline void ej_test_tmpdir(char *dir, size_t n, const char *tag)
{
  const char *base = getenv("TMPDIR");
  if (!base || !*base) base = "/tmp";
  int len = snprintf(dir, n, "%s/ej_%s_XXXXXX", base, tag);
  ck_assert_msg(len > 0 && (size_t)len < n && len < 256, "scratch directory name too long for its buffer");
  ck_assert_msg(mkdtemp(dir) != NULL, "cannot make a scratch directory under %s", base);
  static int registered;
  if (!registered) {
    registered = 1;
    atexit(ej_test_tmpdir_cleanup_);
  }
  if (ej_test_tmpdir_n_ == ej_test_tmpdir_cap_) {
    int cap = ej_test_tmpdir_cap_ ? 2 * ej_test_tmpdir_cap_ : 16;
    ej_test_tmpdir_entry_ *e = realloc(ej_test_tmpdirs_, (size_t)cap * sizeof *e);
    ck_assert_ptr_nonnull(e);
    ej_test_tmpdirs_ = e;
    ej_test_tmpdir_cap_ = cap;
  }
  ej_test_tmpdir_entry_ *e = &ej_test_tmpdirs_[ej_test_tmpdir_n_++];
  snprintf(e->path, sizeof e->path, "%s", dir);
  e->pid = getpid();
}

#endif
