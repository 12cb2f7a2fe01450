#include <terrain/io/genesis.h>
#include <terrain/procedural_map.h>

#include <string>
#include <utility>

namespace terrain::io {

Result<Genesis> makeGenesis(const GenesisOptions& options) {
    DemImportOptions import;
    import.spacing_metres = options.spacing_metres;
    import.patch_tolerance_metres = options.patch_tolerance_metres;
    if (!options.dem.empty()) {
        Result<ImportedDem> dem = importDem(options.dem, import);
        if (!dem)
            return dem.error();
        std::string source = "DEM " + dem->info.name + " (spacing " +
                             std::to_string(dem->info.spacing_metres) + " m from " +
                             dem->info.spacing_source + ")";
        return Genesis{std::move(dem->terrain), std::move(source)};
    }
    if (!options.png.empty()) {
        if (!options.spacing_metres)
            return makeError(
                ErrorCode::kOutOfRange, "a PNG genesis needs a grid spacing (--spacing)");
        Result<ImportedDem> png = importPng(
            options.png, *options.spacing_metres, options.png_vertical_scale, 0.0, import);
        if (!png)
            return png.error();
        return Genesis{std::move(png->terrain), "PNG " + options.png.string()};
    }
    ProceduralMapOptions p;
    p.seed = options.seed;
    p.width = options.size;
    p.height = options.size;
    if (options.spacing_metres)
        p.spacing_metres = *options.spacing_metres;
    if (options.patch_tolerance_metres)
        p.patch_tolerance_metres = *options.patch_tolerance_metres;
    Result<Terrain> map = makeProceduralMap(p);
    if (!map)
        return map.error();
    return Genesis{
        std::move(*map), "procedural map, seed " + std::to_string(options.seed) + ", " +
                             std::to_string(options.size) + " x " + std::to_string(options.size)};
}

} // namespace terrain::io
