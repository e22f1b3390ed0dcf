// Writes the volume-loader test fixtures in tests/fixtures/ with OpenVDB itself (10.0.1 on
// Debian 12), plus a `.expected` sidecar per float grid whose values come from OpenVDB's own
// accessors on the file as OpenVDB reads it back. Built and run by scripts/make_fixtures.sh.

#include <openvdb/openvdb.h>
#include <openvdb/io/File.h>
#include <openvdb/math/Maps.h>

#include <cstdio>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <string>

using namespace openvdb;

static std::string gDir;

/// The analytic pattern the loader tests recompute: 0.01 * (i + 2j + 3k) in bbox-local indices.
static float pattern(int i, int j, int k) { return 0.01f * float(i + 2 * j + 3 * k); }

/// Voxels of the pattern grids that are set inactive (with a non-background inactive value).
static bool holeAt(int i, int j, int k) { return (i * 7 + j * 3 + k) % 11 == 5; }

/// A float grid holding `pattern` over dims voxels starting at index `origin`, with holes.
static FloatGrid::Ptr makePattern(const std::string& name, Coord origin, Coord dims) {
    FloatGrid::Ptr grid = FloatGrid::create(/*background=*/0.0f);
    grid->setName(name);
    grid->setGridClass(GRID_FOG_VOLUME);
    auto acc = grid->getAccessor();
    for (int k = 0; k < dims.z(); ++k)
        for (int j = 0; j < dims.y(); ++j)
            for (int i = 0; i < dims.x(); ++i) {
                const Coord c = origin + Coord(i, j, k);
                if (holeAt(i, j, k)) acc.setValueOff(c, 0.7f);
                else acc.setValueOn(c, pattern(i, j, k));
            }
    return grid;
}

/// Writes `grids` to fixtures/<name> with the given OpenVDB compression flags.
static void writeVdb(const std::string& name, GridPtrVec grids, uint32_t compression) {
    io::File file(gDir + "/" + name);
    file.setCompression(compression);
    file.write(grids);
    file.close();
    std::cout << "wrote " << name << "\n";
}

/// Writes fixtures/<stem>.<gridName>.expected for float grid `gridName`, read back by OpenVDB.
/// Dense values are listed (x fastest) when the active bbox holds at most `maxListed` voxels.
static void writeExpected(const std::string& file, const std::string& gridName, Index64 maxListed) {
    io::File in(gDir + "/" + file);
    in.open();
    FloatGrid::Ptr grid = gridPtrCast<FloatGrid>(in.readGrid(gridName));
    in.close();
    const CoordBBox bbox = grid->evalActiveVoxelBoundingBox();
    const math::Transform& xf = grid->transform();
    const std::string sidecar = file.substr(0, file.rfind('.')) + "." + gridName + ".expected";
    std::ofstream out(gDir + "/" + sidecar);
    out << std::setprecision(17);
    out << "# Written by scripts/make_fixtures.cpp from OpenVDB " << OPENVDB_LIBRARY_VERSION_STRING
        << " reading " << file << " back (accessor values; inactive = background).\n";
    out << "grid " << gridName << "\n";
    out << "bbox_min " << bbox.min().x() << " " << bbox.min().y() << " " << bbox.min().z() << "\n";
    out << "bbox_max " << bbox.max().x() << " " << bbox.max().y() << " " << bbox.max().z() << "\n";
    out << "background " << grid->background() << "\n";
    // World positions of the dense grid's corner (voxel bbox.min's lower corner) and of one
    // voxel step along each axis from it: they pin down the whole index-to-world affine map.
    const Vec3d c0 = bbox.min().asVec3d() - Vec3d(0.5);
    const char* names[4] = {"world_corner", "world_corner_x1", "world_corner_y1", "world_corner_z1"};
    const Vec3d steps[4] = {Vec3d(0.0), Vec3d(1, 0, 0), Vec3d(0, 1, 0), Vec3d(0, 0, 1)};
    for (int n = 0; n < 4; ++n) {
        const Vec3d w = xf.indexToWorld(c0 + steps[n]);
        out << names[n] << " " << w.x() << " " << w.y() << " " << w.z() << "\n";
    }
    double sum = 0.0;
    for (auto it = grid->cbeginValueOn(); it; ++it) sum += double(*it) * double(it.getVoxelCount());
    out << "active_voxel_count " << grid->activeVoxelCount() << "\n";
    out << "active_sum " << sum << "\n";
    const Coord d = bbox.dim();
    if (Index64(d.x()) * Index64(d.y()) * Index64(d.z()) <= maxListed) {
        out << "values\n";
        auto acc = grid->getConstAccessor();
        for (int z = bbox.min().z(); z <= bbox.max().z(); ++z)
            for (int y = bbox.min().y(); y <= bbox.max().y(); ++y)
                for (int x = bbox.min().x(); x <= bbox.max().x(); ++x) {
                    const Coord c(x, y, z);
                    out << (acc.isValueOn(c) ? acc.getValue(c) : grid->background()) << "\n";
                }
    }
    std::cout << "wrote " << sidecar << "\n";
}

/// The pattern grid in every compression and precision the loader must read.
static void writePatternVariants() {
    const Coord origin(-4, 3, -5), dims(20, 12, 9);
    const uint32_t blosc = io::COMPRESS_BLOSC | io::COMPRESS_ACTIVE_MASK;
    const uint32_t zip = io::COMPRESS_ZIP | io::COMPRESS_ACTIVE_MASK;
    writeVdb("density_blosc.vdb", {makePattern("density", origin, dims)}, blosc);
    writeVdb("density_zip.vdb", {makePattern("density", origin, dims)}, zip);
    // No codec, only active-mask compression: with COMPRESS_NONE the four upper nodes' dense
    // value tables alone would take 512 KiB.
    writeVdb("density_raw.vdb", {makePattern("density", origin, dims)}, io::COMPRESS_ACTIVE_MASK);
    FloatGrid::Ptr half = makePattern("density", origin, dims);
    half->setSaveFloatAsHalf(true);
    writeVdb("density_half_blosc.vdb", {half}, blosc);
    writeVdb("density_half_zip.vdb", {half}, zip);
    for (const char* f : {"density_blosc.vdb", "density_zip.vdb", "density_raw.vdb",
                          "density_half_blosc.vdb", "density_half_zip.vdb"})
        writeExpected(f, "density", 100000);
}

/// Non-trivial transforms: scale + translation, and a rotating affine map.
static void writeTransformed() {
    FloatGrid::Ptr st = makePattern("density", Coord(2, -1, 7), Coord(5, 4, 3));
    math::MapBase::Ptr stMap(new math::ScaleTranslateMap(Vec3d(0.5, 0.25, 2.0), Vec3d(1.5, -2.0, 3.0)));
    st->setTransform(math::Transform::Ptr(new math::Transform(stMap)));
    writeVdb("scale_translate.vdb", {st}, io::COMPRESS_BLOSC | io::COMPRESS_ACTIVE_MASK);
    writeExpected("scale_translate.vdb", "density", 100000);

    FloatGrid::Ptr af = makePattern("density", Coord(0, 0, 0), Coord(3, 4, 2));
    math::Mat4d m = math::Mat4d::identity();
    m.preScale(Vec3d(0.1, 0.2, 0.3));
    m.postRotate(math::Z_AXIS, M_PI / 2.0);
    m.postTranslate(Vec3d(10.0, 20.0, 30.0));
    math::MapBase::Ptr afMap(new math::AffineMap(m));
    af->setTransform(math::Transform::Ptr(new math::Transform(afMap)));
    writeVdb("affine.vdb", {af}, io::COMPRESS_BLOSC | io::COMPRESS_ACTIVE_MASK);
    writeExpected("affine.vdb", "density", 100000);
}

/// Active tiles at the lower and upper internal levels, an inactive non-background tile.
static void writeTiles() {
    FloatGrid::Ptr grid = FloatGrid::create(0.0f);
    grid->setName("density");
    grid->fill(CoordBBox(Coord(0, 0, 0), Coord(15, 15, 7)), 0.5f, /*active=*/true);
    grid->tree().addTile(/*level=*/1, Coord(0, 16, 0), 0.9f, /*active=*/false);
    grid->tree().setValueOn(Coord(20, 3, 2), 1.25f);
    grid->tree().setValueOn(Coord(2, 20, 1), 0.3f);
    writeVdb("tiles.vdb", {grid}, io::COMPRESS_BLOSC | io::COMPRESS_ACTIVE_MASK);
    writeExpected("tiles.vdb", "density", 100000);

    FloatGrid::Ptr upper = FloatGrid::create(0.0f);
    upper->setName("density");
    upper->tree().addTile(/*level=*/2, Coord(0, 0, 0), 0.25f, /*active=*/true);
    upper->tree().setValueOn(Coord(130, 1, 2), 1.0f);
    writeVdb("upper_tile.vdb", {upper}, io::COMPRESS_ZIP | io::COMPRESS_ACTIVE_MASK);
    writeExpected("upper_tile.vdb", "density", 0);
}

/// Grids the loader must refuse with a clear message.
static void writeBadGrids() {
    Vec3SGrid::Ptr vel = Vec3SGrid::create(Vec3s(0.0f));
    vel->setName("velocity");
    vel->tree().setValueOn(Coord(1, 2, 3), Vec3s(1.0f, 2.0f, 3.0f));
    vel->tree().setValueOn(Coord(4, 5, 6), Vec3s(-1.0f, 0.5f, 0.0f));
    writeVdb("vec3.vdb", {vel}, io::COMPRESS_BLOSC | io::COMPRESS_ACTIVE_MASK);

    Int32Grid::Ptr ints = Int32Grid::create(0);
    ints->setName("density");
    ints->tree().setValueOn(Coord(1, 2, 3), 7);
    ints->tree().setValueOn(Coord(2, 2, 3), 9);
    writeVdb("int.vdb", {ints}, io::COMPRESS_BLOSC | io::COMPRESS_ACTIVE_MASK);

    FloatGrid::Ptr empty = FloatGrid::create(0.0f);
    empty->setName("density");
    writeVdb("empty.vdb", {empty}, io::COMPRESS_BLOSC | io::COMPRESS_ACTIVE_MASK);

    FloatGrid::Ptr huge = FloatGrid::create(0.0f);
    huge->setName("density");
    huge->tree().setValueOn(Coord(0, 0, 0), 1.0f);
    huge->tree().setValueOn(Coord(2000, 2000, 2000), 1.0f);
    writeVdb("huge.vdb", {huge}, io::COMPRESS_BLOSC | io::COMPRESS_ACTIVE_MASK);

    FloatGrid::Ptr rootTile = FloatGrid::create(0.0f);
    rootTile->setName("density");
    rootTile->tree().addTile(/*level=*/3, Coord(0, 0, 0), 0.1f, /*active=*/true);
    writeVdb("root_tile.vdb", {rootTile}, io::COMPRESS_BLOSC | io::COMPRESS_ACTIVE_MASK);
}

/// A file without a "density" grid: the loader falls back to the first float grid.
static void writeMulti() {
    Vec3SGrid::Ptr vel = Vec3SGrid::create(Vec3s(0.0f));
    vel->setName("velocity");
    vel->tree().setValueOn(Coord(0, 0, 0), Vec3s(1.0f, 0.0f, 0.0f));
    FloatGrid::Ptr temp = makePattern("temperature", Coord(0, 0, 0), Coord(3, 2, 2));
    FloatGrid::Ptr flames = makePattern("flames", Coord(10, 10, 10), Coord(2, 2, 2));
    DoubleGrid::Ptr dbl = DoubleGrid::create(0.0);
    dbl->setName("precise");
    dbl->tree().setValueOn(Coord(-1, 0, 1), 0.125);
    dbl->tree().setValueOn(Coord(1, 0, 1), 2.5);
    writeVdb("multi.vdb", {vel, temp, flames, dbl}, io::COMPRESS_ZIP | io::COMPRESS_ACTIVE_MASK);
    writeExpected("multi.vdb", "temperature", 100000);
    writeExpected("multi.vdb", "flames", 100000);
}

int main(int argc, char** argv) {
    if (argc != 2) {
        std::cerr << "usage: make_fixtures OUTPUT_DIR\n";
        return 2;
    }
    gDir = argv[1];
    openvdb::initialize();
    writePatternVariants();
    writeTransformed();
    writeTiles();
    writeBadGrids();
    writeMulti();
    return 0;
}
