/* The C API's worlds from C (C11, lamina::c only): the cholecystectomy example's liver and
 * gallbladder made from its scene, their names and models, the scene's grasper moving the
 * gallbladder as the world steps, a force on the liver, a dissection dividing ties, a scalpel
 * cutting the liver (renumbered: its model and topology generation follow), a reset putting
 * everything back, and every misuse a status with a one-line message. The example's
 * path comes from the build (LAMINA_EXAMPLES_DIR). Exit code 0 = every check held. */
#include <lamina/c_api.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "c_check.h"

/* Largest distance of body b from its rest positions, mm. */
static double moved(const lamina_world* w, int32_t b) {
  const lamina_model* m = lamina_world_body_model(w, b);
  const int32_t n = lamina_model_node_count(m);
  double* x = malloc(sizeof(double) * 3 * (size_t)n);
  double* rest = malloc(sizeof(double) * 3 * (size_t)n);
  CHECK_OK(lamina_world_body_positions(w, b, x, 3 * (int64_t)n));
  CHECK_OK(lamina_model_rest_positions(m, rest, 3 * (int64_t)n));
  double worst = 0.0;
  for (int32_t i = 0; i < n; ++i) {
    const double dx = x[3 * i] - rest[3 * i], dy = x[3 * i + 1] - rest[3 * i + 1],
                 dz = x[3 * i + 2] - rest[3 * i + 2];
    worst = fmax(worst, sqrt(dx * dx + dy * dy + dz * dz));
  }
  free(x);
  free(rest);
  return worst;
}

int main(void) {
  lamina_world* w = NULL;
  CHECK_OK(lamina_world_create_from_scene(LAMINA_EXAMPLES_DIR "/cholecystectomy.json", &w));
  CHECK(lamina_world_body_count(w) == 2);
  CHECK(strcmp(lamina_world_body_name(w, 0), "liver") == 0);
  CHECK(strcmp(lamina_world_body_name(w, 1), "gallbladder") == 0);
  CHECK(lamina_world_body_name(w, 2) == NULL && lamina_world_body_model(w, -1) == NULL);
  CHECK(lamina_model_node_count(lamina_world_body_model(w, 0)) > 1000);
  CHECK(moved(w, 0) == 0.0 && moved(w, 1) == 0.0);

  /* 0.3 s: the scene's grasper has begun its retraction of the fundus; no blade yet. */
  lamina_world_stats st;
  CHECK_OK(lamina_world_step(w, 300, &st));
  printf(
      "after %lld steps (%.3f s): %lld ties, %lld divided, gallbladder moved %.2f mm, "
      "penetration %.3f mm, step %.0f us (contact %.0f us)\n",
      (long long)st.steps, st.time_s, (long long)st.ties, (long long)st.ties_divided, moved(w, 1),
      st.max_penetration_mm, st.step_us, st.contact_us);
  CHECK(st.steps == 300 && fabs(st.time_s - 0.3) < 1e-9);
  CHECK(st.ties > 100 && st.ties_divided == 0 && st.ties_torn == 0);
  CHECK(moved(w, 1) > 1.0);
  CHECK(st.max_penetration_mm <= 0.5);

  /* A force on the liver's skin node 0; bad bodies and nodes refused with a message. */
  const int32_t node = 0;
  const double push[3] = {0.0, 0.0, 200.0};
  CHECK_OK(lamina_world_set_forces(w, 0, &node, push, 1));
  CHECK(lamina_world_set_forces(w, 2, &node, push, 1) == LAMINA_ERROR_INVALID_INPUT);
  CHECK(strstr(lamina_last_error(), "out of range") != NULL);
  const int32_t off_skin = 1 << 20;
  CHECK(lamina_world_set_forces(w, 0, &off_skin, push, 1) == LAMINA_ERROR_INVALID_INPUT);
  CHECK(strstr(lamina_last_error(), "skin") != NULL);
  const double nan_push[3] = {NAN, 0.0, 0.0};
  CHECK(lamina_world_set_forces(w, 0, &node, nan_push, 1) == LAMINA_ERROR_INVALID_INPUT);
  CHECK_OK(lamina_world_step(w, 50, &st));

  /* The scene's first stroke, swept at once: it divides ties of the bed. */
  const double path[6] = {-84.9, -252.2, 368.2, -79.1, -188.2, 340.6};
  const double dir[3] = {0.867, 0.129, 0.482};
  int32_t divided = -1;
  CHECK(lamina_world_dissect(w, path, 1, dir, 46.0, 3.0, &divided) == LAMINA_ERROR_INVALID_INPUT);
  CHECK_OK(lamina_world_dissect(w, path, 2, dir, 46.0, 3.0, &divided));
  CHECK_OK(lamina_world_step(w, 1, &st));
  printf("a stroke divided %d ties (%lld in all)\n", divided, (long long)st.ties_divided);
  CHECK(divided > 0 && st.ties_divided == divided);

  /* A scalpel: a slit from above across the liver's middle, half its height deep. The liver is
   * renumbered (its model handle describes the cut one, its topology generation moves on, its
   * force is released) and steps on. */
  const lamina_model* liver = lamina_world_body_model(w, 0);
  const int32_t uncut_nodes = lamina_model_node_count(liver);
  double* rest = malloc(sizeof(double) * 3 * (size_t)uncut_nodes);
  CHECK_OK(lamina_model_rest_positions(liver, rest, 3 * (int64_t)uncut_nodes));
  double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
  for (int32_t i = 0; i < uncut_nodes; ++i)
    for (int a = 0; a < 3; ++a)
      lo[a] = fmin(lo[a], rest[3 * i + a]), hi[a] = fmax(hi[a], rest[3 * i + a]);
  free(rest);
  const double my = 0.5 * (lo[1] + hi[1]) + 0.37, top = hi[2] + 5.0;
  const double slit[6] = {lo[0] + 0.3 * (hi[0] - lo[0]), my, top,
                          lo[0] + 0.7 * (hi[0] - lo[0]), my, top};
  const double down[3] = {0.0, 0.0, -1.0};
  int64_t tets = -1;
  CHECK(lamina_world_cut(w, slit, 2, down, -1.0, &tets) == LAMINA_ERROR_INVALID_INPUT);
  CHECK(lamina_world_cut(w, slit, 1, down, 20.0, &tets) == LAMINA_ERROR_INVALID_INPUT);
  const uint32_t gallbladder_topology = lamina_world_body_topology(w, 1);
  CHECK_OK(lamina_world_cut(w, slit, 2, down, 5.0 + 0.5 * (hi[2] - lo[2]), &tets));
  printf("a slit across the liver divided %lld tetrahedra: %d nodes, %d before\n", (long long)tets,
         lamina_model_node_count(liver), uncut_nodes);
  CHECK(tets > 0);
  CHECK(lamina_world_body_model(w, 0) == liver && lamina_model_node_count(liver) > uncut_nodes);
  CHECK(lamina_world_body_topology(w, 0) == 1 &&
        lamina_world_body_topology(w, 1) == gallbladder_topology);
  CHECK_OK(lamina_world_set_forces(w, 0, &node, push, 1));
  CHECK_OK(lamina_world_step(w, 100, &st));
  CHECK(st.max_penetration_mm <= 0.5);
  CHECK(moved(w, 0) < 50.0);

  /* The cut undone: the liver uncut again (renumbered: its forces released), then nothing more
   * to undo; cut again for the reset below. */
  CHECK_OK(lamina_world_undo_cut(w));
  CHECK(lamina_model_node_count(liver) == uncut_nodes && lamina_world_body_topology(w, 0) == 2);
  CHECK(lamina_world_undo_cut(w) == LAMINA_ERROR_INVALID_INPUT);
  CHECK(strstr(lamina_last_error(), "no cut to undo") != NULL);
  CHECK_OK(lamina_world_cut(w, slit, 2, down, 5.0 + 0.5 * (hi[2] - lo[2]), &tets));
  CHECK(tets > 0 && lamina_world_body_topology(w, 0) == 3);
  CHECK_OK(lamina_world_step(w, 10, &st));

  /* A reset: every tie back, the liver uncut, time 0, both bodies at rest (the force is kept:
   * released first). */
  CHECK_OK(lamina_world_set_forces(w, 0, NULL, NULL, 0));
  CHECK_OK(lamina_world_reset(w));
  CHECK_OK(lamina_world_step(w, 0, &st));
  CHECK(st.time_s == 0.0 && st.ties_divided == 0 && moved(w, 0) == 0.0);
  CHECK(lamina_model_node_count(liver) == uncut_nodes && lamina_world_body_topology(w, 0) == 4);
  CHECK(lamina_world_step(w, -1, &st) == LAMINA_ERROR_INVALID_INPUT);
  lamina_world_free(w);

  /* Not a world scene, no file, no handle: refused with a message. */
  lamina_world* none = NULL;
  CHECK(lamina_world_create_from_scene(LAMINA_EXAMPLES_DIR "/scalpel_retraction.json", &none) ==
        LAMINA_ERROR_INVALID_INPUT);
  CHECK(strstr(lamina_last_error(), "not a world scene") != NULL && none == NULL);
  CHECK(lamina_world_create_from_scene("/nonexistent.json", &none) == LAMINA_ERROR_INVALID_INPUT);
  CHECK(lamina_world_step(NULL, 1, &st) == LAMINA_ERROR_INVALID_INPUT);
  CHECK(lamina_world_body_count(NULL) == 0);
  printf("%s (%d failed checks)\n", failures ? "FAILED" : "ok", failures);
  return failures ? 1 : 0;
}
