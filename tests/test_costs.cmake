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
  LaminaRun.ResumeFromACheckpointContinuesBitForBit 17 80
  ResectCli.AModelIsPlannedFromItsOwnSurfaces 8 72
  ResectCli.CouinaudsSegmentsFromOneMergedVesselLabelArePlacedByTheAtlas 9 67
  World.ContactHoldsATwoNewtonPressWithinHalfAMillimetreForceConservedAndComesBackToRest 5 61
  View.RealMouseEventsFromXdotoolDragTheOrgan 11 55
  PressSphere.TheModelThroughItsContactCodeMatchesFiniteElementsOnItsOwnTets 5 49
  LaminaSoak.RandomCutsAmongTheToolsKeepEveryCheck 5 48
  WorldLoop.ALiveForceOnOneBodyPushesTheOtherAndReleasedBothComeBackToRest 5 46
  CutBody.TheTiesFollowTheCopiesAndTheCutBodyStepsOnInContactAndComesBackToRest 5 45
  LaminaValidate.StabilityQuickRunReleasesEveryLoadAndWritesItsReport 6 45
  HapticProxy.AClosedPathThroughTheTissueReturnsNoMoreEnergyThanWasPutIn 28 42
  Simulation.ReleasedModelReturnsToRest 5 39
  ViewSessionTest.ShiftAtReleasePinsTheForceUntilC 3 39
  CutBody.AScalpelMovingThroughABodyCutsItAsItGoesAndEveryTieKeepsItsPoints 4 38
  CouinaudSegments.AnAtlasLiverAsTheOrganVotesForItselfAndGetsItsSegmentsBack 4 37
  Grasp.RetractingThePhantomsEdge30mmIsStableAndItComesBack 6 37
  LaminaSoak.RandomToolsLeaveMemoryFlatNoNanAndTheModelBackAtRest 4 36
  OrganLoopHands.TheGrasperHoldsPullsAndLetsGo 14 36
  Bench.QuickRunReportsEveryKeyForTwoModels 6 35
  World.AttachmentsHoldConserveForceAndTearPastTheirStrength 4 35
  Stability.DeepIndentationPullAndThreeToolsReleaseBackToRest 5 33
  WorldLoopHands.TheGrasperHoldsTheNearestBodyCarriesItWithTheJawsAndOpenedLetsItGo 4 33
  ViewSessionTest.ADragOnTheOrganDentsItAndReleaseLetsItReturnToRest 3 32
  LaminaRun.PhysicalLiverExampleDeformsReturnsAndKeepsItsVolume 6 31
  LaminaRun.WithoutASceneRunsTheDefaultPokeOnThePhantom 6 31
  View.WithoutARateItStepsAtARateTheMachineKeeps 18 31
  Grasp.RetractingTheTotalSegmentatorLiversEdge30mmIsStableAndItComesBack 5 29
  WorldLoop.StepsTheWorldExactlyAsWorldStepAndItsBladesDo 3 28
  Embedding.CApi 2 27
  FemSphere.PressedBlockConvergesAndTheFloorHoldsTheSpheresPush 5 26
  HapticProxy.AStiffCouplingIsBoundedAndRateLimitedAndTheProxyNeverCrosses 13 26
  CouinaudSegments.WithVesselsOnlyLiversWhoseVesselsAreKnownVoteAndAnAtlasLiverGetsItsOwnBack 3 25
  SkinNeighbourhood.TheHapticTipRendersExactlyAsWithAWholeSkinScanEveryStep 13 25
  View.ScriptedDragMovesTheSkinAndReleaseLetsItReturn 4 25
  CouinaudSegments.TheAtlasPlacesTheSegmentsInTheirAnatomicalOrderInTheOrgansBox 3 24
  Simulation.EveryIntegratorReachesTheSameLoadedEquilibrium 3 23
  View.RealMouseEventsFromXdotoolPlanAResectionAndPerformIt 17 23
  CarvedOut.NoEmbeddedVertexMovesMoreThanTwiceItsTetrahedron 4 22
  LaminaRun.TwoToolsAtOnceBothDeformTheSkin 3 22
  WorldLoopHands.TheTipDentsTheBodyItTouchesFeelsItsPushAndLiftedTheBodyComesBack 2 22
  WorldLoopUndo.CutsBeyondTheUndoDepthAreKeptForAResetWhichPutsTheBodiesBackUncut 1 22
  Scalpel.OnACutOrganTheLoadIsTheReactionAndAFreedPieceComesToRest 9 21
  View.RebuildSwapsTheModelUnderTheRunningSimulation 6 21
  WorldViewTest.APinnedForceGoesOnThroughACutOfItsBodyAndCLetsItGo 4 21
  LaminaValidate.RefineBuildsEverySizePressesItToRestAndRefinementSoftensTheDent 5 19
  World.AContactSpringHoldsANodeAtItsPointInsideTheImplicitStepAndLetsGo 8 18
  WorldViewTest.AScalpelDragCutsTheBodyItCrossesWhichIsDrawnAndDraggedOnItsNewNodes 3 18
  BuildEmbedded.AVesselUnderAPushMovesWithTheDent 3 17
  BuildEmbedded.UnderTheDefaultPokeTheStructuresMoveWithTheTissue 3 17
  Embedding.CApiWorld 2 17
  LaminaValidate.TheIndenterRadiusIsTheUsersAndABadOneIsRefused 2 17
  Scalpel.SplittingAlongTheNewPartOnlyLeavesWhatSplittingTheWholePathAfreshWould 3 17
  LaminaRunScalpel.AStoppedRunWithAScalpelResumesBitForBit 4 16
  View.RealMouseEventsFromXdotoolCutTheOrganInScalpelModeAndUUndoesIt 14 16
  WorldViewTest.BothBodiesAndTheTiesAreDrawnAndADragDentsOneThatComesBackWhenReleased 3 16
  Render.WritesAPictureWithNoDisplayAndRejectsBadOptions 2 15
  Simulation.WithDampingAndNoToolEnergyNeverRises 2 15
  StabilityWatch.APokedOrganLetGoIsNeverCalledUnstable 2 15
  World.TheContactSearchSkipsOnlyNodesThatCannotReachASkin 2 15
  Run.RealtimeKeepsItsRateAndReportsTheReaction 3 14
  Serve.TheExamplePolyDataClientGetsTheWholeSkin 8 14
  SkinNeighbourhood.ListsEveryTriangleWithinReachAndScansOnlyWhenTheMarginIsSpent 1 14
  WorldLoop.AnUndoCarriesTheForcesBackToTheNodesTheyCameFrom 2 14
  WorldLoopHands.ACutOfTheHeldBodyCarriesTheGraspToTheCopiesAndAResetOpensIt 2 14
  Contact.AtRestTheTissuePushesBackWithExactlyTheToolsLoad 1 13
  PlanOnModel.GivesTheSegmentationsFunctionalRemnant 3 13
  PlanOnModel.StructuresFromSeparateMasksArePlannedAsStructuresFromLabels 3 13
  WorldLoopParameters.OneBodysMaterialChangesItAloneAndAnUndoKeepsIt 2 13
  WorldLoopUndo.TakesTheLastCutsBackOneAtATimeWithTheirTiesAndTheClockRunsOn 2 13
  WorldViewTest.TheGrasperHoldsTheBodyPressedRetractsItWithTheDragAndLetsGo 3 13
  Scalpel.AProgressiveCutSplitsARealLiversStructuresBesideItIntoClosedPieces 2 12
  WorldLoop.ACutRenumbersTheBodyRefusesItsOldNodesAndAResetPutsItBackUncut 2 12
  LaminaRun.TheDisplaySkinSeriesIsWrittenOnlyWhenAskedFor 1 11
  Render.DrawsTheDisplaySkinAndStructuresAsAskedAndRefusesBadChoices 2 11
  ResectCli.RefusesBadSurfacesWithOneLineAndWritesNothing 4 11
  SpringLanesProduct.ImplicitEulerSettlesWhereExplicitEulerDoes 1 11
  ExplicitLimit.IsBelowTheTrueLimitAtRestOfThePhysicalLiver 2 10
  LaminaRun.EveryEmbeddedSurfaceGetsASeriesAtWx 1 10
  ResectCli.SlicerMarkupsGiveTheSamePlanAsThePlane 3 10
  Serve.WithoutARateItFollowsTheMachineAndAClientMayAskForOne 5 10
  TouchSurface.TheHapticProxyRestsOnTheDisplaySkinAndItsListMatchesAWholeScan 1 10
  View.TheCholecystectomyWorldIsShownInRealTimeAtTheRateTheMachineKeeps 7 10
  Web.MalformedOversizedAndStalledClientsAreDroppedAndTheOthersGoOn 7 10
  World.OneBodyStepsExactlyAsItsSimulationAlone 5 10
  WorldLoop.StaleHandlesOlderTopologiesAndBadCommandsAreRefusedChangingNothing 1 10
  CarryOver.PiecesPulledApartOpenTheCutAndComeBackToRest 4 9
  PlanOnModel.GivesTheSegmentationsPlanFromItsOwnSurfaces 2 9
  Serve.WithSendHzZeroTheRateIsToldOnlyToTheClientWhoseRateItIs 5 9
  VolumeTerm.KeepsTheVolumeUnderLoadAndLeavesTheRestShapeAlone 2 9
  EveryLayout.AVenaCavaTheLiverWrapsAndVeinsThroughItBuildTheWholeOrgan 3 8
  EveryLayout.TheUnionLayoutBuildsWithItsStructuresEmbedded 2 8
  ExplainFailure.EveryAdviceBuildsWhenFollowed 2 8
  LowestFrequency.ByMultigridLobpcgAsByAFactorisation 2 8
  LowestFrequency.MatchesADenseEigensolveAndItsScalingLaws 1 8
  OrganLoop.ReactionBalancesTheHeldLoadAtRest 1 8
  OrganLoopCut.AnUndoKeepsTheParametersSetSinceTheCut 2 8
  PlanOnModel.ACutModelKeepsItsTreesAndTheirFunction 2 8
  PlanResection.MarginsMatchADistanceMapOfTheTumour 2 8
  Scalpel.TheLiveHandsAreCarriedThroughACutWithTheTools 4 8
  Serve.APoseOnTheSkinPushesItAndTheReactionComesBackAgainstThePush 4 8
  Serve.TheExampleTrackerClientDrivesTheToolTip 5 8
  BranchTerritories.OnThePhantomTheyPartitionTheOrganAsItsBuiltTreeDoes 1 7
  CarvedOut.IrcadsLayoutBuildsTheWholeOrganWithItsStructuresInside 2 7
  EveryLayout.SeparateMasksGiveTheStructuresTheirRolesAsLabelsDo 2 7
  KeepPiece.TheRemnantAfterAPlanesCutIsAWholeModelOfItsVolume 2 7
  LaminaRunWorld.ABodysScalpelCutsItAsItMovesAndTheWorldRestsAfter 2 7
  PlanOnModel.FollowsTheShapeItIsGiven 2 7
  PlanOnModel.TheFunctionalRemnantFollowsTheShape 2 7
  PlanOnModel.WithoutTreesTheFunctionalRemnantIsNotClaimed 2 7
  RebuildReadyScene.ResolvesTheMaterialForTheNewModel 2 7
  RunTools.StopsAtRestAfterTheLastReleaseAndNotBefore 3 7
  Serve.AGrasperDeviceHoldsPullsAndLetsGo 3 7
  Serve.BadClientsAreDroppedAndTheRestCarriesOn 3 7
  Simulation.HeldNodesStayWhereTheyAreHeldAndDriveTheRest 1 7
  SurfaceVolumeByPlane.TheSkinSplitsAsTheTetrahedraThatFillIt 2 7
  TetTerm.BitForBitForAThreadCountAndToRoundOffAcrossThem 2 7
  View.ADragThatBlowsTheOrganUpIsShownLoggedAndEndsWithExitFive 5 7
  Web.AnOrgansDragGoesOnThroughACutMadeMeanwhileAndItsReleaseLetsGo 3 7
  Web.TwoPagesAndAnOpenIGTLinkClientAtOnceAndTheServerKeepsItsRateOrSaysSo 4 7
  DisplaySkin.OnAClinicalSizeMaskMeetsTheBudgetVolumeAndDistanceTargets 3 6
  Serve.AScalpelStrokeCutsTheOrganAndTheVesselsCrossedComeBackAsAnEvent 3 6
  Serve.AWorldSendsEachBodysSkinAndTheHandsActOnTheBodyTheyMeet 4 6
  Serve.TheReactionStreamsAtTheStepRateAndTheSkinAtItsOwn 3 6
  ViewSessionTest.AScriptWaitsForTheOrganToSettleAfterItsRelease 4 6
  Web.AWorldDragGoesOnThroughACutMadeMeanwhileAndItsReleaseLetsGo 3 5
  Format.EveryFileIsFormatted 3 3
  Embedding.InstalledPackage 5 0
  Embedding.Python.Examples 12 0
  Embedding.Python.Module 49 0
  Embedding.Python.RunScene 25 0
  Embedding.Python.Scenes 9 0
  Embedding.Python.Serve 18 0
  Embedding.Python.Validate 13 0
  LaminaRunWorld.TheCholecystectomyFreesTheGallbladderAndTheLiverComesBackToRest 9 0
  LaminaValidate.QuickRunComparesTheModelsWithConvergedFiniteElements 11 0
  Web.ThePageInChromiumAndAnEmulatedHeadset 87 0
)
while(lamina_test_costs)
  list(POP_FRONT lamina_test_costs name release sanitizer)
  if(lamina_costs_sanitized)
    set_tests_properties(${name} PROPERTIES COST ${sanitizer})
  else()
    set_tests_properties(${name} PROPERTIES COST ${release})
  endif()
endwhile()
