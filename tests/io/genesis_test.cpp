// The genesis choice every program shares (terrain-server, terrain-sim, terrain-replay's soak):
// the same world as the importer or generator it picks, with the tolerance it is given.

#include <terrain/io/genesis.h>
#include <terrain/procedural_map.h>

#include <gtest/gtest.h>

#include <filesystem>

namespace terrain::io {
namespace {

namespace fs = std::filesystem;

const fs::path kGenesisDemDir = TERRAIN_DEM_DIR;

TEST(Genesis, WithoutAFileItIsTheProceduralMapOfTheSeedAndSize) {
    GenesisOptions g;
    g.seed = 42;
    g.size = 200;
    Result<Genesis> made = makeGenesis(g);
    ASSERT_TRUE(made.ok()) << made.error().message;
    ProceduralMapOptions p;
    p.seed = 42;
    p.width = 200;
    p.height = 200;
    EXPECT_EQ(made->terrain.worldHash(), makeProceduralMap(p)->worldHash());
    EXPECT_NE(made->source.find("seed 42"), std::string::npos) << made->source;
    // a tolerance and a spacing reach the generator
    g.patch_tolerance_metres = 0.25;
    g.spacing_metres = 2.0;
    p.patch_tolerance_metres = 0.25;
    p.spacing_metres = 2.0;
    EXPECT_EQ(makeGenesis(g)->terrain.worldHash(), makeProceduralMap(p)->worldHash());
    EXPECT_NE(makeGenesis(g)->terrain.worldHash(), made->terrain.worldHash());
    EXPECT_EQ(
        makeGenesis(g)->terrain.spec().patch_tolerance,
        makeProceduralMap(p)->spec().patch_tolerance);
}

TEST(Genesis, ADemWinsAndTakesTheToleranceItIsGiven) {
    const fs::path dem = kGenesisDemDir / "msh_crater_2007" / "msh_crater_2007.json";
    if (!fs::exists(dem))
        GTEST_SKIP() << "reference DEM " << dem << " is absent (../shared/data/dem)";
    GenesisOptions g;
    g.dem = dem;
    g.seed = 42; // ignored: the DEM wins
    Result<Genesis> made = makeGenesis(g);
    ASSERT_TRUE(made.ok()) << made.error().message;
    Result<ImportedDem> direct = importDem(dem, DemImportOptions{});
    ASSERT_TRUE(direct.ok());
    EXPECT_EQ(made->terrain.worldHash(), direct->terrain.worldHash());
    EXPECT_EQ(made->source.rfind("DEM ", 0), 0u) << made->source;
    // the server ignored --tolerance for a DEM before 12-06; it is the import's now
    g.patch_tolerance_metres = 0.5;
    DemImportOptions coarse;
    coarse.patch_tolerance_metres = 0.5;
    const Terrain with = std::move(makeGenesis(g)->terrain);
    EXPECT_EQ(with.worldHash(), importDem(dem, coarse)->terrain.worldHash());
    EXPECT_EQ(with.spec().patch_tolerance, importDem(dem, coarse)->terrain.spec().patch_tolerance);
    EXPECT_NE(with.spec().patch_tolerance, made->terrain.spec().patch_tolerance);
}

TEST(Genesis, APngWithoutASpacingIsRefusedByName) {
    GenesisOptions g;
    g.png = "heights.png";
    Result<Genesis> made = makeGenesis(g);
    ASSERT_FALSE(made.ok());
    EXPECT_EQ(made.error().code, ErrorCode::kOutOfRange);
    EXPECT_NE(made.error().message.find("spacing"), std::string::npos);
}

} // namespace
} // namespace terrain::io
