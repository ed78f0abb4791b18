// Messages of particle properties (parallel/properties.hpp): what a ghost or migrant carries,
// in which layout. Local round trips, the same on every rank.
#include "parallel/properties.hpp"

#include <gtest/gtest.h>

#include <cstring>
#include <vector>

using namespace fabrica;

// The refreshing message field by field (parallel/properties.hpp): x of every particle sent,
// then v, then w; unpacked into a contiguous range of ghosts, each ghost gets exactly its source's
// x, v, w and nothing else changes. Checked against the particle-by-particle message of the
// same particles.
TEST(Properties, FieldByFieldMessagesRoundTrip) {
  Particles src;
  for (int a = 0; a < 7; ++a)
    src.add(
        {100 + a, 0.01 * (a + 1), 2650.0, Vec3(a, 0.5 * a, -a), Vec3(1e-3 * a, 2.0, a * a), Vec3(-a, 3.0 * a, 0.25)});
  const std::vector<Index> idx = {5, 1, 6, 1, 0};  // any owned indices, repeats allowed
  std::vector<char> fields, particles;
  pack_fields(src, idx, Message::Refresh, fields);
  pack(src, idx, Message::Refresh, particles);
  ASSERT_EQ(fields.size(), idx.size() * 9 * sizeof(real_t));
  ASSERT_EQ(fields.size(), particles.size());
  // The layout: all x, then all v, then all w.
  for (std::size_t k = 0; k < idx.size(); ++k) {
    Vec3 x, w;
    std::memcpy(x.data(), fields.data() + k * sizeof(Vec3), sizeof(Vec3));
    std::memcpy(w.data(), fields.data() + (2 * idx.size() + k) * sizeof(Vec3), sizeof(Vec3));
    EXPECT_EQ(x, src.x[idx[k]]);
    EXPECT_EQ(w, src.w[idx[k]]);
  }
  Particles a = src, b = src;
  const std::size_t first_a = a.append_ghosts(idx.size()), first_b = b.append_ghosts(idx.size());
  const char* end = unpack_fields(a, first_a, idx.size(), Message::Refresh, fields.data());
  EXPECT_EQ(end, fields.data() + fields.size());
  unpack(b, first_b, idx.size(), Message::Refresh, particles.data());
  for (std::size_t k = 0; k < idx.size(); ++k) {
    const std::size_t g = first_a + k;
    EXPECT_EQ(a.x[g], src.x[idx[k]]);
    EXPECT_EQ(a.v[g], src.v[idx[k]]);
    EXPECT_EQ(a.w[g], src.w[idx[k]]);
    EXPECT_EQ(a.x[g], b.x[g]);
    EXPECT_EQ(a.v[g], b.v[g]);
    EXPECT_EQ(a.w[g], b.w[g]);
    EXPECT_EQ(a.id[g], GlobalId(-1));  // not carried by the refreshing message
  }
  for (std::size_t k = 0; k < src.size(); ++k) EXPECT_EQ(a.x[k], src.x[k]);
}

// The receive places of a field-by-field message (the forward update receives each field
// straight into the ghosts' range): one piece per carried field, at that field's array from
// 'first', sizes as the sender cuts its message (field_piece_bytes), and none for no particle.
TEST(Properties, FieldPiecesAreTheGhostRangesOfEachField) {
  Particles p;
  for (int a = 0; a < 4; ++a) p.add({a, 0.01, 2650.0, Vec3(a, 0, 0)});
  const std::size_t first = p.append_ghosts(3);
  const std::vector<BytePiece> pieces = field_pieces(p, first, 3, Message::Refresh);
  const std::vector<std::size_t> sizes = field_piece_bytes(3, Message::Refresh);
  ASSERT_EQ(pieces.size(), 3u);
  ASSERT_EQ(sizes, std::vector<std::size_t>(3, 3 * sizeof(Vec3)));
  EXPECT_EQ(pieces[0].at, static_cast<void*>(p.x.data() + first));
  EXPECT_EQ(pieces[1].at, static_cast<void*>(p.v.data() + first));
  EXPECT_EQ(pieces[2].at, static_cast<void*>(p.w.data() + first));
  for (std::size_t k = 0; k < 3; ++k) EXPECT_EQ(pieces[k].bytes, sizes[k]);
  EXPECT_TRUE(field_pieces(p, first, 0, Message::Refresh).empty());
  EXPECT_TRUE(field_piece_bytes(0, Message::Refresh).empty());
  // Full messages carry the properties set at creation too (radius, mass, id, material; the
  // moment of inertia and the inverses are derived from them, not sent).
  EXPECT_EQ(field_pieces(p, first, 3, Message::Full).size(), 7u);
  EXPECT_EQ(bytes_per_particle(Message::Full),
            3 * sizeof(Vec3) + 2 * sizeof(real_t) + sizeof(GlobalId) + sizeof(std::uint8_t));
  // The every-step forward message leaves the positions out (the ghosts drift themselves): v, w.
  const std::vector<BytePiece> fwd = field_pieces(p, first, 3, Message::Forward);
  ASSERT_EQ(fwd.size(), 2u);
  EXPECT_EQ(fwd[0].at, static_cast<void*>(p.v.data() + first));
  EXPECT_EQ(fwd[1].at, static_cast<void*>(p.w.data() + first));
  EXPECT_EQ(bytes_per_particle(Message::Forward), 2 * sizeof(Vec3));
  EXPECT_EQ(bytes_per_particle(Message::Refresh), 3 * sizeof(Vec3));
}
