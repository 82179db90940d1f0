#pragma once
// Internal (not installed): how a scene file spells each enum value, written once. The reader
// accepts these names (and lists them, in this order, when a value is not one of them) and the
// *_name() functions of scene.h give them back for summaries and messages.

#include <string_view>
#include <utility>

#include "lamina/interact/tools.h"
#include "lamina/model/build_model.h"
#include "lamina/model/identify_tets.h"
#include "lamina/sim/simulation.h"

namespace lamina::io::detail {

template <class Enum>
using Spelling = std::pair<std::string_view, Enum>;

inline constexpr Spelling<model::Structure> kStructures[] = {
    {"tets", model::Structure::kTetrahedra}, {"links", model::Structure::kLinks}};
inline constexpr Spelling<model::TetElasticity> kTetElasticities[] = {
    {"coupled", model::TetElasticity::kCoupled}, {"springs", model::TetElasticity::kSprings}};
inline constexpr Spelling<sim::TetModel> kTetModels[] = {
    {"springs", sim::TetModel::kSprings}, {"neo_hookean", sim::TetModel::kNeoHookean}};
inline constexpr Spelling<sim::Integrator> kIntegrators[] = {
    {"semi_implicit_euler", sim::Integrator::kSemiImplicitEuler},
    {"implicit_euler", sim::Integrator::kImplicitEuler},
    {"projective", sim::Integrator::kProjective}};
inline constexpr Spelling<sim::Mode> kModes[] = {{"global", sim::Mode::kGlobal},
                                                 {"local", sim::Mode::kLocal}};
inline constexpr Spelling<sim::Preconditioner> kPreconditioners[] = {
    {"auto", sim::Preconditioner::kAuto},
    {"jacobi", sim::Preconditioner::kJacobi},
    {"multigrid", sim::Preconditioner::kMultigrid}};
inline constexpr Spelling<interact::Routing> kRoutings[] = {{"none", interact::Routing::kNone},
                                                            {"paper", interact::Routing::kPaper}};
inline constexpr Spelling<interact::Touch> kTouches[] = {
    {"display_skin", interact::Touch::kDisplaySkin}, {"skin", interact::Touch::kSkin}};

/// The spelling of `value` in `names`; a value the table does not hold (only a cast could make
/// one) gets the first spelling, the default each name function has always fallen back to.
template <class Enum, size_t N>
constexpr std::string_view name_of(const Spelling<Enum> (&names)[N], Enum value) {
  for (const auto& [name, v] : names)
    if (v == value) return name;
  return names[0].first;
}

}  // namespace lamina::io::detail
