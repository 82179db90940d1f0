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
  LaminaValidate.QuickRunComparesTheModelsWithConvergedFiniteElements 9 117
  LaminaValidate.TheIndenterRadiusIsTheUsersAndABadOneIsRefused 9 117
  Embedding.CApi 8 98
  LaminaRun.ResumeFromACheckpointContinuesBitForBit 21 87
  Contact.AtRestTheTissuePushesBackWithExactlyTheToolsLoad 3 57
  SkinNeighbourhood.TheHapticTipRendersExactlyAsWithAWholeSkinScanEveryStep 23 55
  LaminaValidate.StabilityQuickRunReleasesEveryLoadAndWritesItsReport 7 45
  HapticProxy.AClosedPathThroughTheTissueReturnsNoMoreEnergyThanWasPutIn 19 42
  View.RealMouseEventsFromXdotoolDragTheOrgan 14 42
  Simulation.ReleasedModelReturnsToRest 6 41
  Bench.QuickRunReportsEveryKeyForTwoModels 7 34
  LaminaSoak.RandomToolsLeaveMemoryFlatNoNanAndTheModelBackAtRest 5 33
  PressSphere.TheModelThroughItsContactCodeMatchesFiniteElementsOnItsOwnTets 5 33
  Grasp.RetractingThePhantomsEdge30mmIsStableAndItComesBack 7 32
  Stability.DeepIndentationPullAndThreeToolsReleaseBackToRest 6 32
  Grasp.TheRealtimeLoopsGrasperHoldsPullsAndLetsGo 14 31
  HapticProxy.AStiffCouplingIsBoundedAndRateLimitedAndTheProxyNeverCrosses 15 29
  LaminaRun.WithoutASceneRunsTheDefaultPokeOnThePhantom 8 28
  LaminaRun.PhysicalLiverExampleDeformsReturnsAndKeepsItsVolume 8 26
  FemSphere.PressedBlockConvergesAndTheFloorHoldsTheSpheresPush 3 25
  Simulation.EveryIntegratorReachesTheSameLoadedEquilibrium 3 24
  CarvedOut.NoEmbeddedVertexMovesMoreThanTwiceItsTetrahedron 5 23
  LaminaRun.TwoToolsAtOnceBothDeformTheSkin 4 23
  Serve.TheExamplePolyDataClientGetsTheWholeSkin 11 23
  Grasp.RetractingTheTotalSegmentatorLiversEdge30mmIsStableAndItComesBack 6 21
  ViewSessionTest.TheGrasperHoldsTheSkinItPressesFollowsTheDragAndLetsGo 1 20
  DisplaySkin.OnAClinicalSizeMaskMeetsTheBudgetVolumeAndDistanceTargets 6 19
  View.RebuildSwapsTheModelUnderTheRunningSimulation 10 19
  Run.RealtimeKeepsItsRateAndReportsTheReaction 6 16
  BuildEmbedded.AVesselUnderAPushMovesWithTheDent 4 15
  Simulation.WithDampingAndNoToolEnergyNeverRises 3 15
  RebuildReadyScene.ResolvesTheMaterialForTheNewModel 5 14
  StabilityWatch.APokedOrganLetGoIsNeverCalledUnstable 3 14
  ViewSessionTest.ShiftAtReleasePinsTheForceUntilC 1 14
  CarvedOut.IrcadsLayoutBuildsTheWholeOrganWithItsStructuresInside 2 13
  View.ScriptedDragMovesTheSkinAndReleaseLetsItReturn 10 13
  BuildEmbedded.UnderTheDefaultPokeTheStructuresMoveWithTheTissue 6 12
  Render.WritesAPictureWithNoDisplayAndRejectsBadOptions 5 12
  Serve.TheExampleTrackerClientDrivesTheToolTip 7 12
  CarvedOut.LitsLayoutATumourCarvedOutOfTheLiverBuildsTheWholeOrgan 2 11
  ExplicitLimit.IsBelowTheTrueLimitAtRestOfThePhysicalLiver 2 11
  Headless.TheLegendNamesEachStructureInItsColour 2 11
  Serve.AGrasperDeviceHoldsPullsAndLetsGo 5 11
  Serve.APoseOnTheSkinPushesItAndTheReactionComesBackAgainstThePush 6 11
  Serve.BadClientsAreDroppedAndTheRestCarriesOn 5 11
  ViewSessionTest.ADragOnTheOrganDentsItAndReleaseLetsItReturnToRest 1 11
  Camera.ProjectionMapsAPixelRayBackToItsPixel 2 10
  Serve.TheReactionStreamsAtTheStepRateAndTheSkinAtItsOwn 5 10
  SkinNeighbourhood.ListsEveryTriangleWithinReachAndScansOnlyWhenTheMarginIsSpent 1 10
  SpringLanesProduct.ImplicitEulerSettlesWhereExplicitEulerDoes 2 10
  TouchSurface.TheHapticProxyRestsOnTheDisplaySkinAndItsListMatchesAWholeScan 2 10
  VolumeTerm.KeepsTheVolumeUnderLoadAndLeavesTheRestShapeAlone 2 10
  Grasp.NothingUnderTheJawsIsOneClearErrorAndHoldsNothing 2 9
  Headless.DeformedStateAndOverlaysRenderDifferently 3 9
  Headless.PhantomCoversAPlausibleShareWithShading 2 9
  LowestFrequency.ByMultigridLobpcgAsByAFactorisation 2 9
  Render.DrawsTheDisplaySkinAndStructuresAsAskedAndRefusesBadChoices 6 9
  Camera.FramedBesidePanelsEveryNodeIsDrawnInTheFreeColumns 2 8
  Headless.WritesAPng 2 8
  LaminaRun.TheDisplaySkinSeriesIsWrittenOnlyWhenAskedFor 2 8
  LowestFrequency.MatchesADenseEigensolveAndItsScalingLaws 2 8
  RealtimeLoop.ReactionBalancesTheHeldLoadAtRest 1 8
  View.ADragThatBlowsTheOrganUpIsShownLoggedAndEndsWithExitFive 6 8
  Figures.QuickRunWritesEveryFigureAndItsData 3 7
  LaminaRun.EveryEmbeddedSurfaceGetsASeriesAtWx 3 7
  LaminaRun.PaperScenesOnTheSharedLiversConvergeThroughALargeDeformation 3 7
  Multigrid.ReachesJacobisStatesInFewerIterations 2 7
  Simulation.HeldNodesStayWhereTheyAreHeldAndDriveTheRest 2 7
  Simulation.SameResultOnOneAndTwoThreads 3 7
  TetAssembly.ImplicitEulerStepsAsWithTheElementProduct 2 7
  TetTerm.BitForBitForAThreadCountAndToRoundOffAcrossThem 2 7
  RunTools.StopsAtRestAfterTheLastReleaseAndNotBefore 3 6
  Stability.ImplicitEulerAtTenTimesThePapersDt 3 6
  ViewSessionTest.AScriptWaitsForTheOrganToSettleAfterItsRelease 4 5
  CliOptions.EveryHelpIsPrintableText 3 4
  RunTools.WithoutStopAtRestRunsToTheEndTime 3 4
  ViewSessionTest.AScriptWaitsForItsRebuildHoweverLongItTakes 3 4
  Modules.ADownwardIncludeBuilds 4 3
  Embedding.InstalledPackage 12 0
  Embedding.Python.Examples 17 0
  Embedding.Python.Module 7 0
  Embedding.Python.RunScene 23 0
  Embedding.Python.Scenes 11 0
  Embedding.Python.Validate 23 0
)
while(lamina_test_costs)
  list(POP_FRONT lamina_test_costs name release sanitizer)
  if(lamina_costs_sanitized)
    set_tests_properties(${name} PROPERTIES COST ${sanitizer})
  else()
    set_tests_properties(${name} PROPERTIES COST ${release})
  endif()
endwhile()
