# Where ctest starts: the longest tests first, so that the two jobs of `ctest -j2` end together
# instead of one long test running alone at the end. Written by scripts/update_test_costs.sh
# from ctest's own measurements (CTestCostData.txt) of a release suite and a sanitizer suite on a
# 2-core machine; each suite orders its tests by its own column (a test's sanitizer slowdown
# ranges from 3x to 20x, so one order does not fit both). ctest's record of a finished run takes
# over in a build tree that has run before; a fresh clone (CI) starts from this table.
# Included after the tests are discovered (TEST_INCLUDE_FILES of tests/, tests/serve and
# tests/embedding); a test not built in a preset is ignored.
# name, release seconds, sanitizer seconds
set(lamina_test_costs
  LaminaRunWorld.TheCholecystectomyFreesTheGallbladderAndTheLiverComesBackToRest 16 160
  LaminaBuildOrgans.AModelPerOrganAndAWorldSceneOfThemThatRuns 4 35
  World.TheContactSearchSkipsOnlyNodesThatCannotReachASkin 2 20
  World.ContactHoldsATwoNewtonPressWithinHalfAMillimetreForceConservedAndComesBackToRest 10 90
  World.AttachmentsHoldConserveForceAndTearPastTheirStrength 8 70
  LaminaValidate.QuickRunComparesTheModelsWithConvergedFiniteElements 12 121
  LaminaRun.ResumeFromACheckpointContinuesBitForBit 18 64
  LaminaValidate.StabilityQuickRunReleasesEveryLoadAndWritesItsReport 8 51
  View.RealMouseEventsFromXdotoolDragTheOrgan 11 49
  Simulation.ReleasedModelReturnsToRest 7 42
  HapticProxy.AClosedPathThroughTheTissueReturnsNoMoreEnergyThanWasPutIn 19 41
  LaminaSoak.RandomToolsLeaveMemoryFlatNoNanAndTheModelBackAtRest 5 36
  PressSphere.TheModelThroughItsContactCodeMatchesFiniteElementsOnItsOwnTets 4 35
  OrganLoopHands.TheGrasperHoldsPullsAndLetsGo 15 32
  HapticProxy.AStiffCouplingIsBoundedAndRateLimitedAndTheProxyNeverCrosses 16 31
  Stability.DeepIndentationPullAndThreeToolsReleaseBackToRest 6 31
  FemSphere.PressedBlockConvergesAndTheFloorHoldsTheSpheresPush 3 30
  Bench.QuickRunReportsEveryKeyForTwoModels 6 29
  Grasp.RetractingThePhantomsEdge30mmIsStableAndItComesBack 7 29
  LaminaRun.PhysicalLiverExampleDeformsReturnsAndKeepsItsVolume 6 29
  Embedding.CApi 4 27
  LaminaRun.WithoutASceneRunsTheDefaultPokeOnThePhantom 6 27
  SkinNeighbourhood.TheHapticTipRendersExactlyAsWithAWholeSkinScanEveryStep 10 26
  Grasp.RetractingTheTotalSegmentatorLiversEdge30mmIsStableAndItComesBack 6 25
  Simulation.EveryIntegratorReachesTheSameLoadedEquilibrium 3 25
  ViewSessionTest.TheGrasperHoldsTheSkinItPressesFollowsTheDragAndLetsGo 1 22
  CarvedOut.NoEmbeddedVertexMovesMoreThanTwiceItsTetrahedron 5 19
  LaminaRun.TwoToolsAtOnceBothDeformTheSkin 3 18
  Simulation.WithDampingAndNoToolEnergyNeverRises 2 17
  LaminaValidate.TheIndenterRadiusIsTheUsersAndABadOneIsRefused 3 16
  LaminaValidate.RefineBuildsEverySizePressesItToRestAndRefinementSoftensTheDent 4 30
  Run.RealtimeKeepsItsRateAndReportsTheReaction 4 16
  Serve.TheExamplePolyDataClientGetsTheWholeSkin 9 16
  StabilityWatch.APokedOrganLetGoIsNeverCalledUnstable 3 15
  View.RebuildSwapsTheModelUnderTheRunningSimulation 6 15
  ViewSessionTest.ShiftAtReleasePinsTheForceUntilC 1 15
  BuildEmbedded.AVesselUnderAPushMovesWithTheDent 4 14
  BuildEmbedded.UnderTheDefaultPokeTheStructuresMoveWithTheTissue 4 14
  Contact.AtRestTheTissuePushesBackWithExactlyTheToolsLoad 1 13
  ExplicitLimit.IsBelowTheTrueLimitAtRestOfThePhysicalLiver 2 13
  SkinNeighbourhood.ListsEveryTriangleWithinReachAndScansOnlyWhenTheMarginIsSpent 1 13
  ViewSessionTest.ADragOnTheOrganDentsItAndReleaseLetsItReturnToRest 1 13
  SpringLanesProduct.ImplicitEulerSettlesWhereExplicitEulerDoes 1 12
  TouchSurface.TheHapticProxyRestsOnTheDisplaySkinAndItsListMatchesAWholeScan 2 12
  DisplaySkin.OnAClinicalSizeMaskMeetsTheBudgetVolumeAndDistanceTargets 4 11
  LowestFrequency.ByMultigridLobpcgAsByAFactorisation 2 11
  Render.WritesAPictureWithNoDisplayAndRejectsBadOptions 2 11
  VolumeTerm.KeepsTheVolumeUnderLoadAndLeavesTheRestShapeAlone 2 11
  CarryOver.PiecesPulledApartOpenTheCutAndComeBackToRest 3 10
  LaminaRun.EveryEmbeddedSurfaceGetsASeriesAtWx 1 10
  LaminaRun.TheDisplaySkinSeriesIsWrittenOnlyWhenAskedFor 2 10
  Render.DrawsTheDisplaySkinAndStructuresAsAskedAndRefusesBadChoices 3 10
  Serve.AGrasperDeviceHoldsPullsAndLetsGo 5 10
  Serve.TheExampleTrackerClientDrivesTheToolTip 5 10
  Simulation.HeldNodesStayWhereTheyAreHeldAndDriveTheRest 2 10
  View.ScriptedDragMovesTheSkinAndReleaseLetsItReturn 7 10
  LaminaRun.PaperScenesOnTheRealLiversConvergeThroughALargeDeformation 2 9
  LowestFrequency.MatchesADenseEigensolveAndItsScalingLaws 2 9
  Multigrid.ReachesJacobisStatesInFewerIterations 2 9
  OrganLoop.ReactionBalancesTheHeldLoadAtRest 1 9
  RebuildReadyScene.ResolvesTheMaterialForTheNewModel 2 9
  Serve.APoseOnTheSkinPushesItAndTheReactionComesBackAgainstThePush 4 9
  TetAssembly.ImplicitEulerStepsAsWithTheElementProduct 2 9
  TetTerm.BitForBitForAThreadCountAndToRoundOffAcrossThem 2 9
  CarvedOut.IrcadsLayoutBuildsTheWholeOrganWithItsStructuresInside 3 8
  RunTools.StopsAtRestAfterTheLastReleaseAndNotBefore 3 8
  Simulation.SameResultOnOneAndTwoThreads 2 8
  Stability.ImplicitEulerAtTenTimesThePapersDt 2 8
  CarvedOut.LitsLayoutATumourCarvedOutOfTheLiverBuildsTheWholeOrgan 2 7
  Serve.BadClientsAreDroppedAndTheRestCarriesOn 3 7
  Serve.TheReactionStreamsAtTheStepRateAndTheSkinAtItsOwn 3 7
  View.ADragThatBlowsTheOrganUpIsShownLoggedAndEndsWithExitFive 5 7
  ViewSessionTest.AScriptWaitsForTheOrganToSettleAfterItsRelease 4 6
  Figures.QuickRunWritesEveryFigureAndItsData 3 5
  Embedding.InstalledPackage 10 0
  Embedding.Python.Examples 13 0
  Embedding.Python.Module 19 0
  Embedding.Python.RunScene 21 0
  Embedding.Python.Scenes 14 0
  Embedding.Python.Validate 14 0
)
while(lamina_test_costs)
  list(POP_FRONT lamina_test_costs name release sanitizer)
  if(lamina_costs_sanitized)
    set_tests_properties(${name} PROPERTIES COST ${sanitizer})
  else()
    set_tests_properties(${name} PROPERTIES COST ${release})
  endif()
endwhile()

# The longest end-to-end runs under the sanitizers, left out of CI's sanitizer stage (`ctest -LE
# "browser|long_end_to_end"` in .ci/run) and run in the release suite, the README's command: on
# 2026-12-02 this 2-core machine ran the sanitizer suite in 61 minutes, at half the speed these
# costs were measured at, and CI's whole run came within minutes of its 90-minute limit. Each
# took 5-7 minutes under ASan (the cholecystectomy's `lamina run` 416 s, `lamina validate
# --quick` 307 s; the browser test, label browser, 438 s); what they run is under the sanitizers
# in shorter tests (World.*, CutBody.*, WorldLoop*, FemSphere.*, PressSphere.*, Web.*, Serve.*).
foreach(name IN ITEMS LaminaRunWorld.TheCholecystectomyFreesTheGallbladderAndTheLiverComesBackToRest
                      LaminaValidate.QuickRunComparesTheModelsWithConvergedFiniteElements)
  set_tests_properties(${name} PROPERTIES LABELS long_end_to_end)
endforeach()
