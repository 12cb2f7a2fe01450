// The split/merge policy alone, on a small diamond space with a fake mesh: the order of splits
// and merges, the frame's budget, candidates looked at again only once the eye has travelled
// far enough, culled candidates watched, and the threshold following the triangle cap.

#include <terrain/roam/split_merge.h>

#include <gtest/gtest.h>

#include <map>
#include <vector>

namespace terrain::testing {
namespace {

using roam::Box;
using roam::DiamondId;
using roam::DiamondSpace;
using roam::FrameStats;
using roam::SplitMerge;
using roam::SplitMergeMesh;

/// Diamonds as boxes in front of (or behind) a camera at the origin looking along +x; splitting
/// and merging flips their kActive bit, up to `budget` of them a frame.
struct FakeMesh final : SplitMergeMesh {
    explicit FakeMesh(DiamondSpace& s) : space(s) {}
    Extent extentOf(DiamondId id) const override { return extents.at(id); }
    bool split(DiamondId id, FrameStats& stats) override {
        if (refuse) {
            ++stats.refused_by_cap;
            return false;
        }
        space.state(id) |= DiamondSpace::kActive;
        ++stats.splits;
        ++spent;
        splits.push_back(id);
        return true;
    }
    void merge(DiamondId id, FrameStats& stats) override {
        space.state(id) = static_cast<std::uint8_t>(space.state(id) & ~DiamondSpace::kActive);
        ++stats.merges;
        ++spent;
        merges.push_back(id);
    }
    bool budgetSpent(FrameStats&) const override { return spent >= budget; }

    /// Diamond `id`: a 1 m box `distance` metres along x (negative: behind the eye) with error
    /// bound `delta` metres.
    void place(DiamondId id, double distance, double delta) {
        Box b;
        b.lo = {distance, -0.5, -0.5};
        b.hi = {distance + 1.0, 0.5, 0.5};
        extents[id] = {b, delta};
    }
    DiamondSpace& space;
    std::map<DiamondId, Extent> extents;
    std::vector<DiamondId> splits;
    std::vector<DiamondId> merges;
    int budget = 1000;
    int spent = 0;
    bool refuse = false;
};

roam::Camera camera() {
    roam::Camera c;
    c.eye = {0.0, 0.0, 0.0};
    c.forward = {1.0, 0.0, 0.0};
    c.up = {0.0, 0.0, 1.0};
    return c;
}

struct Policy {
    Policy() : policy(space, 1.0, 4.0), mesh(space) {
        space.reset(16, roam::BoundsCodec(1.0 / 1024.0));
        space.resizeCentres(0);
        policy.resizeIds(space.eagerCount(), space.pooledCounts());
        policy.restartSweep(camera());
    }
    double priority(DiamondId id) const {
        return metric.screenError(mesh.extents.at(id).box, mesh.extents.at(id).delta);
    }
    /// A frame that travelled `metres`; the mesh's budget starts again.
    FrameStats frame(double metres, double* bound = nullptr) {
        FrameStats stats;
        mesh.spent = 0;
        const double b = policy.frame(metric, metres, stats, mesh);
        if (bound != nullptr)
            *bound = b;
        return stats;
    }
    DiamondSpace space;
    SplitMerge policy;
    FakeMesh mesh;
    roam::ViewMetric metric{camera()};
};

TEST(RoamSplitMerge, SplitsGoHighestFirstWithinTheBudgetAndTheRestWaitsForTheNextFrame) {
    Policy p;
    for (DiamondId id = 0; id < 5; ++id) {
        p.mesh.place(id, 10.0, 0.1 * (id + 1)); // priorities rise with the id, all above tau
        p.policy.offer(id, DiamondSpace::kSplitCandidate);
    }
    ASSERT_GT(p.priority(0), 1.0);
    p.mesh.budget = 3;
    double bound = 0.0;
    const FrameStats first = p.frame(0.0, &bound);
    EXPECT_EQ(p.mesh.splits, (std::vector<DiamondId>{4, 3, 2}));
    EXPECT_EQ(first.evaluations, 5);
    EXPECT_DOUBLE_EQ(bound, p.priority(1)) << "the largest priority left waiting bounds the mesh";
    EXPECT_TRUE(first.budget_exhausted || first.splits == 3);
    p.frame(0.0, &bound);
    EXPECT_EQ(p.mesh.splits, (std::vector<DiamondId>{4, 3, 2, 1, 0})) << "due again at once";
    EXPECT_DOUBLE_EQ(bound, 1.0);
}

TEST(RoamSplitMerge, MergesGoLowestFirst) {
    Policy p;
    const double distances[] = {20.0, 80.0, 40.0};
    for (DiamondId id = 0; id < 3; ++id) {
        p.mesh.place(id, distances[id], 0.001); // far below tau
        p.space.state(id) = DiamondSpace::kActive;
        p.policy.offer(id, DiamondSpace::kMergeCandidate);
    }
    p.frame(0.0);
    EXPECT_EQ(p.mesh.merges, (std::vector<DiamondId>{1, 2, 0}));
}

TEST(RoamSplitMerge, ACandidateIsLookedAtAgainOnlyOnceTheEyeHasTravelledFarEnough) {
    Policy p;
    p.mesh.place(7, 10.0, 0.002); // under tau at 10 m; crosses it about 1.2 m from the box
    ASSERT_LT(p.priority(7), 1.0);
    p.policy.offer(7, DiamondSpace::kSplitCandidate);
    EXPECT_EQ(p.frame(0.0).evaluations, 1);
    EXPECT_EQ(p.policy.candidateCount(), 1u) << "keyed in the heap";
    const double crossing = p.metric.errorScale() * 0.002 / 1.0;
    const double key = 10.0 - crossing;
    EXPECT_EQ(p.frame(0.5 * key).evaluations, 0) << "not due yet";
    EXPECT_EQ(p.frame(0.4 * key).evaluations, 0);
    EXPECT_EQ(p.frame(0.2 * key).evaluations, 1) << "due once the travel passed its key";
    EXPECT_TRUE(p.mesh.splits.empty()) << "the fake box did not come closer";
}

TEST(RoamSplitMerge, ACulledCandidateThatWantsASplitIsWatchedEveryFrame) {
    Policy p;
    p.mesh.place(3, -10.0, 0.5); // behind the eye: above tau, but out of view
    p.policy.offer(3, DiamondSpace::kSplitCandidate);
    for (int f = 0; f < 3; ++f) {
        EXPECT_EQ(p.frame(0.0).evaluations, 1) << f;
        EXPECT_NE(p.space.state(3) & DiamondSpace::kWatched, 0);
    }
    EXPECT_TRUE(p.mesh.splits.empty());
}

TEST(RoamSplitMerge, TheThresholdRisesWhenTheCapRefusesAndFallsBackToTauWhenThereIsRoom) {
    Policy p;
    FrameStats refused;
    refused.refused_by_cap = 5;
    p.policy.followCap(refused, 1000, 1000, true);
    EXPECT_NEAR(p.policy.threshold(), 1.1, 1e-12) << "one step of 10 %";
    const FrameStats quiet;
    p.policy.followCap(quiet, 100, 1000, false);
    EXPECT_NEAR(p.policy.threshold(), 1.1, 1e-12) << "not while the pool refused lately";
    p.policy.followCap(quiet, 100, 1000, true);
    EXPECT_NEAR(p.policy.threshold(), 1.1 / 1.05, 1e-12);
    p.policy.followCap(quiet, 100, 1000, true);
    EXPECT_EQ(p.policy.threshold(), 1.0) << "never below tau";
    p.policy.followCap(quiet, 950, 1000, true);
    EXPECT_EQ(p.policy.threshold(), 1.0);
}

TEST(RoamSplitMerge, ShortStepsKeepWhatTheBudgetLeftInABacklogAndPriceAgainOnlyItsBest) {
    Policy p;
    p.policy.setBacklogPull(2); // short steps: two of each kind priced again per step
    for (DiamondId id = 0; id < 6; ++id) {
        p.mesh.place(id, 10.0, 0.1 * (id + 1));
        p.policy.offer(id, DiamondSpace::kSplitCandidate);
    }
    p.mesh.budget = 2;
    FrameStats first = p.frame(0.0);
    EXPECT_EQ(first.evaluations, 6);
    EXPECT_EQ(p.mesh.splits, (std::vector<DiamondId>{5, 4}));
    EXPECT_EQ(first.backlog, 4);
    EXPECT_EQ(p.policy.candidateCount(), 0u) << "the backlog is not the heap";
    FrameStats second = p.frame(0.0);
    EXPECT_EQ(second.evaluations, 2) << "only the backlog's best two, priced again";
    EXPECT_EQ(p.mesh.splits, (std::vector<DiamondId>{5, 4, 3, 2}));
    p.frame(0.0);
    EXPECT_EQ(p.mesh.splits, (std::vector<DiamondId>{5, 4, 3, 2, 1, 0}));
    EXPECT_EQ(p.frame(0.0).backlog, 0);
    // back to whole frames: what waited is due at once
    p.policy.setBacklogPull(2);
    for (DiamondId id = 6; id < 9; ++id) {
        p.mesh.place(id, 10.0, 0.05 * (id + 1));
        p.policy.offer(id, DiamondSpace::kSplitCandidate);
    }
    p.mesh.budget = 1;
    p.frame(0.0);
    p.policy.setBacklogPull(SplitMerge::kPullAll);
    p.mesh.budget = 1000;
    EXPECT_EQ(p.frame(0.0).evaluations, 2);
    EXPECT_EQ(p.mesh.splits.size(), 9u);
}

TEST(RoamSplitMerge, AMergeWaitsForTheBandBelowTheThreshold) {
    Policy p;
    p.policy.setMergeBand(0.5);
    p.mesh.place(1, 10.0, 0.004);
    const double at10 = p.priority(1);
    ASSERT_LT(at10, 1.0);
    ASSERT_GT(at10, 0.5);
    p.space.state(1) = DiamondSpace::kActive;
    p.policy.offer(1, DiamondSpace::kMergeCandidate);
    p.frame(0.0);
    EXPECT_TRUE(p.mesh.merges.empty()) << "under the threshold, but above half of it";
    EXPECT_EQ(p.policy.candidateCount(), 1u);
    // further away (the fake box moved): due once the eye could have taken it under the band
    p.mesh.place(1, 40.0, 0.004);
    ASSERT_LT(p.priority(1), 0.5);
    const double crossing = p.metric.errorScale() * 0.004 / 1.0;
    p.frame(0.9 * (crossing / 0.5 - 10.0));
    EXPECT_TRUE(p.mesh.merges.empty()) << "not due yet";
    p.frame(0.2 * (crossing / 0.5 - 10.0));
    EXPECT_EQ(p.mesh.merges, (std::vector<DiamondId>{1}));
}

TEST(RoamSplitMerge, EqualPrioritiesGoInTheOrderOfTheirIdsWhateverTheOrderOffered) {
    for (const bool reversed : {false, true}) {
        Policy p;
        for (int k = 0; k < 6; ++k) {
            const DiamondId id =
                reversed ? static_cast<DiamondId>(5 - k) : static_cast<DiamondId>(k);
            p.mesh.place(id, -10.0, 0.001); // behind the eye: culled, priority 0
            p.space.state(id) = DiamondSpace::kActive;
            p.policy.offer(id, DiamondSpace::kMergeCandidate);
        }
        p.mesh.budget = 3;
        p.frame(0.0);
        EXPECT_EQ(p.mesh.merges, (std::vector<DiamondId>{5, 4, 3})) << reversed;
    }
}

} // namespace
} // namespace terrain::testing
