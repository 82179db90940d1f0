# Where ctest starts: the longest tests first, so that the two jobs of `ctest -j2` end together
# instead of one long test running alone at the end (set_tests_properties on a test that is not
# built in this preset is ignored by ctest). The tests added with add_test() carry their COST
# where they are added.
# COST is seconds as measured by ctest in a release suite on a 2-core machine (2026-11-25; the
# sanitizer suite keeps about the same order, about 3x slower); ctest's own record of a finished
# run (Testing/Temporary/CTestCostData.txt) takes over in a build that has run before. Tests
# under a second are left to ctest's order. Remeasure: the cost file after a run.
# Included after the tests are discovered (TEST_INCLUDE_FILES of tests/ and tests/serve).
set(lamina_test_costs
  LaminaRun.ResumeFromACheckpointContinuesBitForBit 22
  View.RealMouseEventsFromXdotoolDragTheOrgan 14
  View.RebuildSwapsTheModelUnderTheRunningSimulation 11
  Serve.TheExamplePolyDataClientGetsTheWholeSkin 11
  View.ScriptedDragMovesTheSkinAndReleaseLetsItReturn 10
  LaminaValidate.QuickRunComparesTheModelsWithConvergedFiniteElements 8
  LaminaValidate.TheIndenterRadiusIsTheUsersAndABadOneIsRefused 8
  LaminaRun.WithoutASceneRunsTheDefaultPokeOnThePhantom 8
  LaminaRun.PhysicalLiverExampleDeformsReturnsAndKeepsItsVolume 8
  Serve.TheExampleTrackerClientDrivesTheToolTip 7
  LaminaValidate.StabilityQuickRunReleasesEveryLoadAndWritesItsReport 7
  Bench.QuickRunReportsEveryKeyForTwoModels 7
  Stability.DeepIndentationPullAndThreeToolsReleaseBackToRest 6
  Serve.APoseOnTheSkinPushesItAndTheReactionComesBackAgainstThePush 6
  Run.RealtimeKeepsItsRateAndReportsTheReaction 6
  Simulation.ReleasedModelReturnsToRest 5
  Serve.TheReactionStreamsAtTheStepRateAndTheSkinAtItsOwn 5
  Serve.BadClientsAreDroppedAndTheRestCarriesOn 5
  Render.WritesAPictureWithNoDisplayAndRejectsBadOptions 5
  RebuildReadyScene.ResolvesTheMaterialForTheNewModel 5
  LaminaSoak.RandomToolsLeaveMemoryFlatNoNanAndTheModelBackAtRest 5
  LaminaRun.TwoToolsAtOnceBothDeformTheSkin 4
  ViewSessionTest.AScriptWaitsForItsRebuildHoweverLongItTakes 3
  Stability.ImplicitEulerAtTenTimesThePapersDt 3
  Simulation.WithDampingAndNoToolEnergyNeverRises 3
  Simulation.SameResultOnOneAndTwoThreads 3
  Simulation.EveryIntegratorReachesTheSameLoadedEquilibrium 3
  RunTools.WithoutStopAtRestRunsToTheEndTime 3
  RunTools.StopsAtRestAfterTheLastReleaseAndNotBefore 3
  LaminaRun.PaperScenesOnTheSharedLiversConvergeThroughALargeDeformation 3
  Headless.DeformedStateAndOverlaysRenderDifferently 3
  Figures.QuickRunWritesEveryFigureAndItsData 3
  CliOptions.EveryHelpIsPrintableText 3
  VolumeTerm.KeepsTheVolumeUnderLoadAndLeavesTheRestShapeAlone 2
  ViewSessionTest.AScriptedRebuildSwapsTheModelUnderTheRunningSimulation 2
  TetTerm.BitForBitForAThreadCountAndToRoundOffAcrossThem 2
  TetAssembly.ImplicitEulerStepsAsWithTheElementProduct 2
  SpringLanesProduct.IsTheSameOnOneAndTwoThreads 2
  SpringLanesProduct.ImplicitEulerSettlesWhereExplicitEulerDoes 2
  Simulation.HeldNodesStayWhereTheyAreHeldAndDriveTheRest 2
  ResolveMaterial.TetrahedraCarryEAndNuThemselves 2
  RealtimeLoop.ThreadNeverOutrunsItsRateAndStopsPromptly 2
  LowestFrequency.MatchesADenseEigensolveAndItsScalingLaws 2
  LayerOrder.RestIsOrderedAndAnInnerNodePushedOutIsCaught 2
  LayerOrder.AnInvertedTetrahedronIsCaught 2
  LaminaSoak.RandomToolsMoveALocalModeModel 2
  LaminaRun.PaperExampleConvergesAndWritesAPlayableSeries 2
  LaminaRun.BadSceneIsOneLineExitTwoAndNoOutput 2
  LaminaRun.ALoadBeyondRecoveryStopsCleanlyWithExitFive 2
  LaminaRun.ABadCheckpointOrAChangedSceneIsRefused 2
  Headless.WritesAPng 2
  Headless.PhantomCoversAPlausibleShareWithShading 2
  ExplicitLimit.IsBelowTheTrueLimitAtRestOfThePhysicalLiver 2
  CliWorkflow.PhantomBuildInfoExport 2
  Camera.ProjectionMapsAPixelRayBackToItsPixel 2
  BuildModel.SixLayersNestOnThePhantom 2
  # Issue 33's (the fresh-clone CI of 2026-11-26, a loaded machine: high by up to 2x)
  DisplaySkin.OnAClinicalSizeMaskMeetsTheBudgetVolumeAndDistanceTargets 7
  BuildEmbedded.UnderTheDefaultPokeTheStructuresMoveWithTheTissue 7
  Render.DrawsTheDisplaySkinAndStructuresAsAskedAndRefusesBadChoices 6
  LaminaRun.EveryEmbeddedSurfaceGetsASeriesAtWx 3
)
while(lamina_test_costs)
  list(POP_FRONT lamina_test_costs name cost)
  set_tests_properties(${name} PROPERTIES COST ${cost})
endwhile()
