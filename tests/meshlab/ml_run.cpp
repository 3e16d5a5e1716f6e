// Runs one filter of the nhnet MeshLab plugin on a PLY file with the parameters the plugin's
// initParameterSet gives (what MeshLab's filter dialog shows before the user changes anything),
// calling the plugins the way meshlabserver does: MeshLab's io_base plugin reads and writes the
// PLY (so a PLY camera element becomes the mesh's shot), the filter runs through applyFilter with
// its log. meshlabserver itself cannot run a filter with its defaults: it asserts unless the
// script lists every parameter.
//   ml_run IO_BASE.so FILTER.so IN.ply OUT.ply "FILTER NAME"
// Prints the filter's log; exit 0 on success, 1 when the filter failed, 2 on bad use.
#include <common/interfaces.h>
#include <wrap/io_trimesh/io_mask.h>

#include <QApplication>
#include <QPluginLoader>

#include <cstdio>

namespace {

template <class T>
T* load(const char* path) {
  QPluginLoader loader(path);
  T* p = qobject_cast<T*>(loader.instance());
  if (p == nullptr)
    std::fprintf(stderr, "ml_run: cannot load %s: %s\n", path,
                 qUtf8Printable(loader.errorString()));
  return p;
}

bool progress(const int, const char*) { return true; }

QAction* find_action(MeshFilterInterface& filter, const QString& name) {
  for (QAction* a : filter.actions())
    if (a->text() == name) return a;
  return nullptr;
}

void print_log(const GLLogStream& log) {
  QStringList lines;
  log.print(lines);
  for (const QString& l : lines) std::printf("%s\n", qUtf8Printable(l));
}

bool save(MeshIOInterface& io, MeshModel& mm, const QString& path) {
  RichParameterList par;
  io.initSaveParameter("ply", mm, par);
  if (par.hasParameter("Binary")) par.setValue("Binary", BoolValue(true));
  return io.save("ply", path, mm, vcg::tri::io::Mask::IOM_VERTNORMAL, par);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 6) {
    std::fprintf(stderr, "usage: ml_run IO_BASE.so FILTER.so IN.ply OUT.ply \"FILTER NAME\"\n");
    return 2;
  }
  QApplication app(argc, argv);
  auto* io = load<MeshIOInterface>(argv[1]);
  auto* filter = load<MeshFilterInterface>(argv[2]);
  if (io == nullptr || filter == nullptr) return 2;
  MeshDocument md;
  MeshModel* mm = md.addNewMesh("", "in", true);
  int mask = 0;
  RichParameterList pre;
  io->initPreOpenParameter("ply", argv[3], pre);
  if (!io->open("ply", argv[3], *mm, mask, pre)) {
    std::fprintf(stderr, "ml_run: cannot open %s\n", argv[3]);
    return 2;
  }
  QAction* action = find_action(*filter, argv[5]);
  if (action == nullptr) return 2;
  RichParameterList par;
  filter->initParameterSet(action, *mm, par);  // the defaults, nothing changed
  GLLogStream log;
  filter->setLog(&log);
  const bool ok = filter->applyFilter(action, md, par, progress);
  print_log(log);
  if (!ok) return 1;
  return save(*io, *mm, argv[4]) ? 0 : 2;
}
