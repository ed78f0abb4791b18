#include "io/mpi/verify.hpp"

#include "core/errors.hpp"
#include "io/mpi/h5.hpp"

#include <chrono>
#include <vector>

namespace fabrica {

VerifyReport verify_run_file(const std::string& path) {
  const auto t0 = std::chrono::steady_clock::now();
  VerifyReport r;
  try {
    const h5::File f = h5::File::open_read(path);
    std::vector<std::string> names;
    f.check(H5Ovisit(
                f.id(), H5_INDEX_NAME, H5_ITER_INC,
                [](hid_t, const char* name, const H5O_info_t* info, void* p) -> herr_t {
                  if (info->type == H5O_TYPE_DATASET) static_cast<std::vector<std::string>*>(p)->emplace_back(name);
                  return 0;
                },
                &names),
            "listing the datasets");
    for (const std::string& n : names) {
      const h5::Dataset d = f.open_dataset(n);
      r.bytes += double(d.verify());
      ++r.datasets;
      if (d.has_checksum()) ++r.checksummed;
    }
  } catch (const h5::Error& e) { throw InputError(e.what()); }
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return r;
}

}  // namespace fabrica
