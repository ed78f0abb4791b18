#include "io/mpi/field_history.hpp"

#include "parallel/byte_buffer.hpp"
#include "parallel/exchange.hpp"

#include <algorithm>
#include <stdexcept>

namespace fabrica {
namespace {

struct Item {
  GlobalId id;
  Vec3 x;
  real_t radius;
};

// The items of every rank at their home ranks (id mod P), in increasing id order. Collective.
std::vector<Item> to_homes(MPI_Comm comm, std::vector<Item> mine) {
  int size = 1;
  MPI_Comm_size(comm, &size);
  if (size > 1) {
    std::vector<std::vector<char>> out(static_cast<std::size_t>(size));
    for (const Item& it : mine) {
      std::vector<char>& b = out[std::size_t(std::uint64_t(it.id) % std::uint64_t(size))];
      put(b, it.id), put(b, it.x), put(b, it.radius);
    }
    mine.clear();
    mine.shrink_to_fit();
    const std::vector<std::vector<char>> in = exchange_all(comm, out);
    for (const std::vector<char>& b : in)
      for (const char* at = b.data(); at < b.data() + b.size();) {
        Item it;
        it.id = get<GlobalId>(at), it.x = get<Vec3>(at), it.radius = get<real_t>(at);
        mine.push_back(it);
      }
  }
  std::sort(mine.begin(), mine.end(), [](const Item& a, const Item& b) { return a.id < b.id; });
  for (std::size_t k = 1; k < mine.size(); ++k)
    if (mine[k].id == mine[k - 1].id)
      throw std::logic_error("FieldHistory: particle " + std::to_string(mine[k].id) + " given twice");
  return mine;
}

}  // namespace

FieldHistory::Step FieldHistory::advance(MPI_Comm comm, const Particles& p, const Instant& now) {
  std::vector<Item> mine(p.n_owned());
  for (std::size_t i = 0; i < p.n_owned(); ++i) mine[i] = {p.id[i], p.x[i], p.radius[i]};
  const std::vector<Item> here = to_homes(comm, std::move(mine));
  Step s;
  if (at_ && at_->case_name == now.case_name) {
    s.from = at_;
    // Both lists in increasing id order: the ids found at both instants.
    std::size_t k = 0;
    for (const Item& it : here) {
      while (k < id_.size() && id_[k] < it.id) ++k;
      if (k < id_.size() && id_[k] == it.id) s.motions.push_back({x_[k], it.x, it.radius});
    }
  }
  id_.resize(here.size());
  x_.resize(here.size());
  for (std::size_t k = 0; k < here.size(); ++k) id_[k] = here[k].id, x_[k] = here[k].x;
  at_ = now;
  return s;
}

void FieldHistory::adopt(MPI_Comm comm, const Instant& at, std::span<const GlobalId> ids, std::span<const Vec3> x) {
  if (ids.size() != x.size()) throw std::logic_error("FieldHistory::adopt: as many positions as ids");
  std::vector<Item> mine(ids.size());
  for (std::size_t k = 0; k < ids.size(); ++k) mine[k] = {ids[k], x[k], 0.0};
  const std::vector<Item> here = to_homes(comm, std::move(mine));
  id_.resize(here.size());
  x_.resize(here.size());
  for (std::size_t k = 0; k < here.size(); ++k) id_[k] = here[k].id, x_[k] = here[k].x;
  at_ = at;
}

void FieldHistory::rename(const std::string& case_name) {
  if (at_) at_->case_name = case_name;
}

void FieldHistory::clear() {
  at_.reset();
  id_.clear();
  x_.clear();
}

}  // namespace fabrica
