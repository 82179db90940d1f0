/* The C API from C (compiled as C11, linked with lamina::c only): a game engine's plugin
 * builds the phantom, holds its back, pushes it with a tool tip, reads the positions and the
 * reaction force, lifts the tip and waits for rest; and every misuse returns a status with a
 * one-line message instead of crashing. Exit code 0 = every check held. */
#include <lamina/c_api.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "c_check.h"

int main(void) {
  lamina_model* model = NULL;
  CHECK_OK(lamina_model_build("phantom", &model));
  const int32_t n = lamina_model_node_count(model);
  const int32_t skin = lamina_model_skin_node_count(model);
  const int32_t triangles = lamina_model_skin_triangle_count(model);
  printf("phantom: %d nodes, %d skin nodes, %d skin triangles, %d layers\n", n, skin, triangles,
         lamina_model_layer_count(model));
  CHECK(n > skin && skin > 0 && triangles > 0 && lamina_model_layer_count(model) >= 2);

  /* A closed triangulated sphere-like skin: Euler's formula F = 2V - 4. */
  CHECK(triangles == 2 * skin - 4);
  int32_t* tri = malloc(sizeof(int32_t) * 3 * (size_t)triangles);
  CHECK_OK(lamina_model_skin_triangles(model, tri, 3 * (int64_t)triangles));
  for (int64_t k = 0; k < 3 * (int64_t)triangles; ++k) CHECK(tri[k] >= 0 && tri[k] < skin);
  free(tri);

  /* Hold the posterior 10 mm (largest y), push the most anterior skin node (smallest y). */
  double* rest = malloc(sizeof(double) * 3 * (size_t)n);
  CHECK_OK(lamina_model_rest_positions(model, rest, 3 * (int64_t)n));
  double y_max = -1e300;
  int32_t front = 0;
  for (int32_t i = 0; i < n; ++i) y_max = fmax(y_max, rest[3 * i + 1]);
  for (int32_t i = 0; i < skin; ++i)
    if (rest[3 * i + 1] < rest[3 * front + 1]) front = i;
  int32_t* fixed = malloc(sizeof(int32_t) * (size_t)n);
  int32_t fixed_count = 0;
  for (int32_t i = 0; i < n; ++i)
    if (rest[3 * i + 1] > y_max - 10.0) fixed[fixed_count++] = i;
  CHECK(fixed_count > 0);

  lamina_material material;
  lamina_material_defaults(&material);
  lamina_solver solver;
  lamina_solver_defaults(&solver);
  CHECK(material.stiffness_n_per_m == 3.0 && solver.dt_s == 0.01);
  solver.integrator = LAMINA_IMPLICIT_EULER;
  /* Implicit Euler at 5 times the paper's dt: the soft springs creep back to rest for over a
   * minute of simulated time (below), 7,000 steps at 10 ms, the most of this test's 97 s under
   * ASan; at 50 ms a fifth of them. */
  solver.dt_s = 0.05;
  /* The paper's soft springs creep back slowly: "at rest" at 1 um/s, not the default 0.1 mm/s. */
  solver.rest_speed_mm_per_s = 1e-3;
  lamina_sim* sim = NULL;
  CHECK_OK(lamina_sim_create(model, &material, &solver, fixed, fixed_count, &sim));
  free(fixed);
  lamina_model_free(model); /* the simulation keeps its own reference */
  CHECK(lamina_sim_node_count(sim) == n);
  CHECK(lamina_model_node_count(lamina_sim_model(sim)) == n);

  /* The display skin, carried by the tetrahedra: at rest its vertices are where they were built. */
  const lamina_model* simulated = lamina_sim_model(sim);
  CHECK(lamina_model_embedded_count(simulated) >= 1);
  lamina_embedded_info skin_info;
  CHECK_OK(lamina_model_embedded_info(simulated, 0, &skin_info));
  printf("embedded 0: '%s', label %d, %d vertices, %d triangles\n", skin_info.name, skin_info.label,
         skin_info.vertex_count, skin_info.triangle_count);
  CHECK(strcmp(skin_info.name, "display_skin") == 0 && skin_info.label == 0);
  const int32_t ev = skin_info.vertex_count;
  CHECK(ev > skin && skin_info.triangle_count > 2 * skin);
  int32_t* etri = malloc(sizeof(int32_t) * 3 * (size_t)skin_info.triangle_count);
  CHECK_OK(
      lamina_model_embedded_triangles(simulated, 0, etri, 3 * (int64_t)skin_info.triangle_count));
  for (int64_t k = 0; k < 3 * (int64_t)skin_info.triangle_count; ++k)
    CHECK(etri[k] >= 0 && etri[k] < ev);
  free(etri);
  double* erest = malloc(sizeof(double) * 3 * (size_t)ev);
  double* ex = malloc(sizeof(double) * 3 * (size_t)ev);
  CHECK_OK(lamina_model_embedded_rest_positions(simulated, 0, erest, 3 * (int64_t)ev));
  CHECK_OK(lamina_sim_embedded_positions(sim, 0, ex, 3 * (int64_t)ev));
  for (int64_t k = 0; k < 3 * (int64_t)ev; ++k) CHECK(fabs(ex[k] - erest[k]) < 1e-9);
  int32_t efront = 0; /* the display skin's vertex nearest the front node */
  for (int32_t v = 0; v < ev; ++v) {
    double d = 0.0, best = 0.0;
    for (int c = 0; c < 3; ++c) {
      d += pow(erest[3 * v + c] - rest[3 * front + c], 2);
      best += pow(erest[3 * efront + c] - rest[3 * front + c], 2);
    }
    if (d < best) efront = v;
  }
  /* Misuse: a surface the model has not, a buffer too small. */
  CHECK(lamina_model_embedded_info(simulated, 99, &skin_info) == LAMINA_ERROR_INVALID_INPUT);
  CHECK(strstr(lamina_last_error(), "embedded surfaces") != NULL);
  CHECK(lamina_sim_embedded_positions(sim, -1, ex, 3 * (int64_t)ev) == LAMINA_ERROR_INVALID_INPUT);
  CHECK(lamina_sim_embedded_positions(sim, 0, ex, 3) == LAMINA_ERROR_INVALID_INPUT);
  CHECK(lamina_model_embedded_count(NULL) == 0);

  /* A 5 mm tip whose surface is 3 mm past the front node, moving +y into the organ. */
  const double radius = 5.0;
  const double tip[3] = {rest[3 * front], rest[3 * front + 1] - radius + 3.0, rest[3 * front + 2]};
  CHECK_OK(lamina_sim_set_tool_tip(sim, tip, radius, 200.0));
  lamina_step_stats st;
  CHECK_OK(lamina_sim_step(sim, 60, &st));
  printf("pushed: t = %.2f s, max displacement %.3f mm, reaction (%.2f, %.2f, %.2f) mN\n",
         st.time_s, st.max_displacement_mm, st.reaction_mn[0], st.reaction_mn[1],
         st.reaction_mn[2]);
  CHECK(fabs(st.time_s - 3.0) < 1e-9 && st.steps == 60);
  CHECK(st.tool_tip_touching == 1);
  CHECK(st.max_displacement_mm > 0.5);
  /* The tissue pushes back against the tool (-y), and mostly along the push. */
  CHECK(st.reaction_mn[1] < -10.0);
  CHECK(fabs(st.reaction_mn[0]) < fabs(st.reaction_mn[1]) &&
        fabs(st.reaction_mn[2]) < fabs(st.reaction_mn[1]));
  double* x = malloc(sizeof(double) * 3 * (size_t)n);
  CHECK_OK(lamina_sim_positions(sim, x, 3 * (int64_t)n));
  CHECK(x[3 * front + 1] > rest[3 * front + 1] + 0.5); /* the front moved in */
  for (int64_t k = 0; k < 3 * (int64_t)n; ++k) CHECK(isfinite(x[k]));
  /* The display skin moved with the nodes: its front too. */
  CHECK_OK(lamina_sim_embedded_positions(sim, 0, ex, 3 * (int64_t)ev));
  printf("display skin front moved %.3f mm in y\n", ex[3 * efront + 1] - erest[3 * efront + 1]);
  CHECK(ex[3 * efront + 1] > erest[3 * efront + 1] + 0.3);
  for (int64_t k = 0; k < 3 * (int64_t)ev; ++k) CHECK(isfinite(ex[k]));
  free(ex);
  free(erest);

  /* Lift the tip: the organ comes back to rest where it was (within 0.1 mm of 2.8; the
   * paper's soft springs and unit masses creep the last tenths of a millimetre for a minute). */
  CHECK_OK(lamina_sim_clear_tool_tip(sim));
  int rested = 0;
  for (int k = 0; k < 1000 && !rested; ++k) {
    CHECK_OK(lamina_sim_step(sim, 10, &st));
    rested = st.at_rest;
  }
  printf("released: t = %.2f s, at rest %d, max displacement %.4f mm\n", st.time_s, st.at_rest,
         st.max_displacement_mm);
  CHECK(rested && st.max_displacement_mm < 0.1 && st.tool_tip_touching == 0);
  CHECK(fabs(st.reaction_mn[1]) < 1e-9);

  /* A grasper: the jaws close on the front of the skin, pull it 5 mm out over 50 steps (the
   * tissue pulls back: +y on the tools), and let go: back to rest. Nothing under the jaws is
   * refused. */
  CHECK_OK(lamina_sim_positions(sim, x, 3 * (int64_t)n));
  const double grasped_at = x[3 * front + 1]; /* where the jaws close (the soft springs creep) */
  double jaws[3] = {rest[3 * front], rest[3 * front + 1], rest[3 * front + 2]};
  CHECK_OK(lamina_sim_set_grasper(sim, jaws, 3.0));
  CHECK_OK(lamina_sim_step(sim, 1, &st)); /* the jaws close where they are at the next step */
  for (int k = 1; k <= 50; ++k) {
    jaws[1] = rest[3 * front + 1] - 0.1 * k;
    CHECK_OK(lamina_sim_set_grasper(sim, jaws, 3.0));
    CHECK_OK(lamina_sim_step(sim, 1, &st));
  }
  CHECK_OK(lamina_sim_positions(sim, x, 3 * (int64_t)n));
  printf("grasped: %d nodes, front at %.3f mm (closed at %.3f), pull %.1f mN\n", st.grasped_nodes,
         x[3 * front + 1], grasped_at, st.reaction_mn[1]);
  CHECK(st.grasped_nodes > 0 && fabs(x[3 * front + 1] - (grasped_at - 5.0)) < 1e-6);
  CHECK(st.reaction_mn[1] > 0.0);
  CHECK_OK(lamina_sim_release_grasper(sim));
  rested = 0;
  for (int k = 0; k < 1000 && !rested; ++k) {
    CHECK_OK(lamina_sim_step(sim, 10, &st));
    rested = st.at_rest;
  }
  CHECK(rested && st.max_displacement_mm < 0.1 && st.grasped_nodes == 0);
  const double nowhere[3] = {0.0, -1e4, 0.0};
  CHECK(lamina_sim_set_grasper(sim, nowhere, 3.0) == LAMINA_ERROR_INVALID_INPUT);
  CHECK(strstr(lamina_last_error(), "nothing under the jaws") != NULL);

  /* Misuse: a status and a one-line message, never a crash. */
  lamina_model* missing = NULL;
  CHECK(lamina_model_load("/nonexistent/liver.vtu", &missing) == LAMINA_ERROR_INVALID_INPUT);
  CHECK(missing == NULL && strstr(lamina_last_error(), "/nonexistent/liver.vtu") != NULL);
  CHECK(strchr(lamina_last_error(), '\n') == NULL);
  const int32_t bad_node = skin + 5;
  const double force[3] = {0.0, 100.0, 0.0};
  CHECK(lamina_sim_set_forces(sim, &bad_node, force, 1) == LAMINA_ERROR_INVALID_INPUT);
  CHECK(strstr(lamina_last_error(), "skin_nodes[0]") != NULL);
  const double nan_tip[3] = {NAN, 0.0, 0.0};
  CHECK(lamina_sim_set_tool_tip(sim, nan_tip, radius, 200.0) == LAMINA_ERROR_INVALID_INPUT);
  CHECK(lamina_sim_set_haptic_limits(sim, -1.0, 0.05) == LAMINA_ERROR_INVALID_INPUT);
  CHECK(lamina_sim_set_haptic_limits(sim, 3.0, 0.0) == LAMINA_ERROR_INVALID_INPUT);
  CHECK_OK(lamina_sim_set_haptic_limits(sim, 3.0, 0.05));
  CHECK(lamina_sim_step(NULL, 1, &st) == LAMINA_ERROR_INVALID_INPUT);
  CHECK(lamina_sim_positions(sim, x, 3) == LAMINA_ERROR_INVALID_INPUT);
  CHECK(strstr(lamina_last_error(), "needed") != NULL);
  solver.integrator = 7;
  lamina_sim* bad = NULL;
  CHECK(lamina_sim_create(lamina_sim_model(sim), NULL, &solver, NULL, 0, &bad) ==
        LAMINA_ERROR_INVALID_INPUT);
  CHECK(bad == NULL && strstr(lamina_last_error(), "integrator") != NULL);
  material.damping_kg_per_s = -1.0;
  CHECK(lamina_sim_create(lamina_sim_model(sim), &material, NULL, NULL, 0, &bad) ==
        LAMINA_ERROR_INVALID_INPUT);
  printf("refused as expected: %s\n", lamina_last_error());
  /* Neo-Hookean tetrahedra from the material struct: a physical tissue (E, lumped masses) whose
   * tetrahedra store stable Neo-Hookean steps under a tool tip, and a model number that is not
   * one is refused by name. */
  lamina_material neo;
  lamina_material_defaults(&neo);
  CHECK(neo.tet_model == LAMINA_TETS_SPRINGS);
  neo.stiffness_n_per_m = 0.0;
  neo.node_mass_kg = 0.0;
  neo.young_modulus_kpa = 6.0;
  neo.poisson_ratio = 0.45;
  neo.tet_model = LAMINA_TETS_NEO_HOOKEAN;
  lamina_solver neo_solver;
  lamina_solver_defaults(&neo_solver);
  neo_solver.integrator = LAMINA_IMPLICIT_EULER;
  neo_solver.dt_s = 0.001;
  lamina_sim* neo_sim = NULL;
  CHECK_OK(lamina_sim_create(lamina_sim_model(sim), &neo, &neo_solver, NULL, 0, &neo_sim));
  const double neo_tip[3] = {rest[3 * front], rest[3 * front + 1] - radius + 2.0,
                             rest[3 * front + 2]};
  CHECK_OK(lamina_sim_set_tool_tip(neo_sim, neo_tip, radius, 200.0));
  lamina_step_stats neo_st;
  CHECK_OK(lamina_sim_step(neo_sim, 50, &neo_st));
  CHECK(neo_st.max_displacement_mm > 0.0 && neo_st.max_displacement_mm < 10.0);
  lamina_sim_free(neo_sim);
  neo.tet_model = 7;
  CHECK(lamina_sim_create(lamina_sim_model(sim), &neo, NULL, NULL, 0, &bad) ==
        LAMINA_ERROR_INVALID_INPUT);
  CHECK(bad == NULL && strstr(lamina_last_error(), "tet_model") != NULL);
  /* A success clears the message. */
  CHECK_OK(lamina_sim_step(sim, 1, NULL));
  CHECK(lamina_last_error()[0] == '\0');

  /* A case built to explode: a tool tip a million times too stiff drives the skin farther than
   * the organ is wide. Within a few dozen steps the status is UNSTABLE with one line saying
   * why; the positions stay finite, no more steps are taken, the reaction a haptic device
   * would render is zero, and a reset steps again. */
  CHECK_OK(lamina_sim_set_tool_tip(sim, tip, radius, 2e8));
  lamina_status blown = LAMINA_OK;
  for (int k = 0; k < 5 && blown == LAMINA_OK; ++k) blown = lamina_sim_step(sim, 10, &st);
  CHECK(blown == LAMINA_ERROR_UNSTABLE);
  printf("exploded as built: %s\n", lamina_last_error());
  CHECK(strstr(lamina_last_error(), "unstable at t = ") != NULL);
  CHECK(strchr(lamina_last_error(), '\n') == NULL);
  CHECK_OK(lamina_sim_positions(sim, x, 3 * (int64_t)n));
  for (int64_t k = 0; k < 3 * (int64_t)n; ++k) CHECK(isfinite(x[k]));
  CHECK(lamina_sim_step(sim, 5, NULL) == LAMINA_ERROR_UNSTABLE);
  CHECK_OK(lamina_sim_clear_tool_tip(sim));
  CHECK_OK(lamina_sim_reset(sim));
  CHECK_OK(lamina_sim_step(sim, 5, &st));
  CHECK(st.max_displacement_mm < 1e-6 && st.reaction_mn[1] == 0.0);
  lamina_sim_free(sim);

  /* A scene: the default physical liver on the phantom, as `lamina run` sets it up. */
  lamina_sim* scene = NULL;
  CHECK_OK(lamina_sim_create_from_scene("phantom", &scene));
  CHECK_OK(lamina_sim_step(scene, 20, &st));
  CHECK(st.steps == 20 && st.max_displacement_mm < 1e-6 && st.at_rest);
  /* A cut across the whole organ, through its middle: two pieces, more nodes, the model
   * handle now the cut one, and it steps on at rest. A path of one point changes nothing. */
  {
    const int32_t before = lamina_sim_node_count(scene);
    const double path[6] = {0.3, -200.0, -200.0, 0.3, 200.0, -200.0};
    const double down[3] = {0.0, 0.0, 1.0};
    lamina_cut_report cut;
    CHECK(lamina_sim_cut(scene, path, 1, down, 400.0, &cut) == LAMINA_ERROR_INVALID_INPUT);
    CHECK(lamina_sim_node_count(scene) == before);
    CHECK_OK(lamina_sim_cut(scene, path, 2, down, 400.0, &cut));
    printf("cut: %lld tetrahedra divided, %d nodes added, %d pieces (largest %.1f mL)\n",
           (long long)cut.cut_tets, cut.new_nodes, cut.pieces, cut.largest_piece_ml);
    CHECK(cut.cut_tets > 0 && cut.pieces == 2 && cut.new_nodes > 0);
    CHECK(lamina_sim_node_count(scene) == before + cut.new_nodes);
    CHECK(lamina_model_node_count(lamina_sim_model(scene)) == before + cut.new_nodes);
    CHECK_OK(lamina_sim_step(scene, 20, &st));
    CHECK(st.max_displacement_mm < 1e-3);
  }
  lamina_sim_free(scene);
  CHECK(lamina_sim_create_from_scene("/nonexistent/scene.json", &scene) ==
        LAMINA_ERROR_INVALID_INPUT);

  free(rest);
  free(x);
  printf("%s (%d failed checks)\n", failures ? "FAILED" : "ok", failures);
  return failures ? 1 : 0;
}
