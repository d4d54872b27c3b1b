#include "spirv/find_sites.hpp"

#include <map>
#include <set>
#include <unordered_map>

#include "spirv/resolve.hpp"

namespace tally::spirv {

Stage stageOf(spv::ExecutionModel model) {
  using M = spv::ExecutionModel;
  switch (model) {
    case M::Vertex: return Stage::Vertex;
    case M::TessellationControl: return Stage::TessControl;
    case M::TessellationEvaluation: return Stage::TessEval;
    case M::Geometry: return Stage::Geometry;
    case M::Fragment: return Stage::Fragment;
    case M::GLCompute: return Stage::Compute;
    case M::TaskEXT: case M::TaskNV: return Stage::Task;
    case M::MeshEXT: case M::MeshNV: return Stage::Mesh;
    default: return Stage::Other;
  }
}

namespace {

struct Access {
  SiteKind kind;
  uint32_t operand;  // word index of the image / pointer operand
  bool isImage;      // operand is an image value (else a pointer)
};

const char* opcodeName(spv::Op op) {
  using O = spv::Op;
  switch (op) {
    case O::OpImageSampleImplicitLod: return "OpImageSampleImplicitLod";
    case O::OpImageSampleExplicitLod: return "OpImageSampleExplicitLod";
    case O::OpImageSampleDrefImplicitLod: return "OpImageSampleDrefImplicitLod";
    case O::OpImageSampleDrefExplicitLod: return "OpImageSampleDrefExplicitLod";
    case O::OpImageSampleProjImplicitLod: return "OpImageSampleProjImplicitLod";
    case O::OpImageSampleProjExplicitLod: return "OpImageSampleProjExplicitLod";
    case O::OpImageSampleProjDrefImplicitLod: return "OpImageSampleProjDrefImplicitLod";
    case O::OpImageSampleProjDrefExplicitLod: return "OpImageSampleProjDrefExplicitLod";
    case O::OpImageFetch: return "OpImageFetch";
    case O::OpImageGather: return "OpImageGather";
    case O::OpImageDrefGather: return "OpImageDrefGather";
    case O::OpImageRead: return "OpImageRead";
    case O::OpImageWrite: return "OpImageWrite";
    case O::OpImageSparseSampleImplicitLod: return "OpImageSparseSampleImplicitLod";
    case O::OpImageSparseSampleExplicitLod: return "OpImageSparseSampleExplicitLod";
    case O::OpImageSparseSampleDrefImplicitLod: return "OpImageSparseSampleDrefImplicitLod";
    case O::OpImageSparseSampleDrefExplicitLod: return "OpImageSparseSampleDrefExplicitLod";
    case O::OpImageSparseSampleProjImplicitLod: return "OpImageSparseSampleProjImplicitLod";
    case O::OpImageSparseSampleProjExplicitLod: return "OpImageSparseSampleProjExplicitLod";
    case O::OpImageSparseSampleProjDrefImplicitLod: return "OpImageSparseSampleProjDrefImplicitLod";
    case O::OpImageSparseSampleProjDrefExplicitLod: return "OpImageSparseSampleProjDrefExplicitLod";
    case O::OpImageSparseFetch: return "OpImageSparseFetch";
    case O::OpImageSparseGather: return "OpImageSparseGather";
    case O::OpImageSparseDrefGather: return "OpImageSparseDrefGather";
    case O::OpImageSparseRead: return "OpImageSparseRead";
    case O::OpLoad: return "OpLoad";
    case O::OpStore: return "OpStore";
    case O::OpCopyMemory: return "OpCopyMemory";
    case O::OpCopyMemorySized: return "OpCopyMemorySized";
    case O::OpAtomicLoad: return "OpAtomicLoad";
    case O::OpAtomicStore: return "OpAtomicStore";
    case O::OpAtomicExchange: return "OpAtomicExchange";
    case O::OpAtomicCompareExchange: return "OpAtomicCompareExchange";
    case O::OpAtomicCompareExchangeWeak: return "OpAtomicCompareExchangeWeak";
    case O::OpAtomicIIncrement: return "OpAtomicIIncrement";
    case O::OpAtomicIDecrement: return "OpAtomicIDecrement";
    case O::OpAtomicIAdd: return "OpAtomicIAdd";
    case O::OpAtomicISub: return "OpAtomicISub";
    case O::OpAtomicSMin: return "OpAtomicSMin";
    case O::OpAtomicUMin: return "OpAtomicUMin";
    case O::OpAtomicSMax: return "OpAtomicSMax";
    case O::OpAtomicUMax: return "OpAtomicUMax";
    case O::OpAtomicAnd: return "OpAtomicAnd";
    case O::OpAtomicOr: return "OpAtomicOr";
    case O::OpAtomicXor: return "OpAtomicXor";
    case O::OpAtomicFAddEXT: return "OpAtomicFAddEXT";
    case O::OpAtomicFMinEXT: return "OpAtomicFMinEXT";
    case O::OpAtomicFMaxEXT: return "OpAtomicFMaxEXT";
    default: return "Op?";
  }
}

// Texture-read opcodes: image operand at word 3.
bool isTextureRead(spv::Op op) {
  using O = spv::Op;
  switch (op) {
    case O::OpImageSampleImplicitLod: case O::OpImageSampleExplicitLod:
    case O::OpImageSampleDrefImplicitLod: case O::OpImageSampleDrefExplicitLod:
    case O::OpImageSampleProjImplicitLod: case O::OpImageSampleProjExplicitLod:
    case O::OpImageSampleProjDrefImplicitLod: case O::OpImageSampleProjDrefExplicitLod:
    case O::OpImageFetch: case O::OpImageGather: case O::OpImageDrefGather: case O::OpImageRead:
    case O::OpImageSparseSampleImplicitLod: case O::OpImageSparseSampleExplicitLod:
    case O::OpImageSparseSampleDrefImplicitLod: case O::OpImageSparseSampleDrefExplicitLod:
    case O::OpImageSparseSampleProjImplicitLod: case O::OpImageSparseSampleProjExplicitLod:
    case O::OpImageSparseSampleProjDrefImplicitLod: case O::OpImageSparseSampleProjDrefExplicitLod:
    case O::OpImageSparseFetch: case O::OpImageSparseGather: case O::OpImageSparseDrefGather:
    case O::OpImageSparseRead: return true;
    default: return false;
  }
}

// Atomic opcodes and the word index of their pointer operand (0: not atomic).
uint32_t atomicPointer(spv::Op op) {
  using O = spv::Op;
  switch (op) {
    case O::OpAtomicStore: case O::OpAtomicFlagClear: return 1;
    case O::OpAtomicLoad: case O::OpAtomicExchange: case O::OpAtomicCompareExchange:
    case O::OpAtomicCompareExchangeWeak: case O::OpAtomicIIncrement: case O::OpAtomicIDecrement:
    case O::OpAtomicIAdd: case O::OpAtomicISub: case O::OpAtomicSMin: case O::OpAtomicUMin:
    case O::OpAtomicSMax: case O::OpAtomicUMax: case O::OpAtomicAnd: case O::OpAtomicOr:
    case O::OpAtomicXor: case O::OpAtomicFAddEXT: case O::OpAtomicFMinEXT: case O::OpAtomicFMaxEXT:
    case O::OpAtomicFlagTestAndSet: return 3;
    default: return 0;
  }
}

bool isBufferClass(std::optional<spv::StorageClass> sc) {
  return sc == spv::StorageClass::StorageBuffer || sc == spv::StorageClass::Uniform ||
         sc == spv::StorageClass::PhysicalStorageBuffer;
}

class Scanner {
 public:
  Scanner(const Module& m, const DefIndex& d, const Types& t) : module_(m), defs_(d), types_(t), resolver_(m, d, t) {
    for (size_t i = 0; i < m.functions.size(); ++i) functionIndex_[m.functions[i].id()] = static_cast<int>(i);
    for (const auto& import : m.imports) {
      if (import.literalString(2) == "NonSemantic.Shader.DebugInfo.100") debugInfo_ = import.resultId();
    }
  }

  Result<SiteScan> run() {
    for (size_t i = 0; i < module_.entryPoints.size(); ++i) {
      const Instruction& ep = module_.entryPoints[i];
      EntryPoint e;
      e.model = static_cast<spv::ExecutionModel>(ep.word(1));
      e.stage = stageOf(e.model);
      e.function = ep.word(2);
      e.name = ep.literalString(3);
      e.instIndex = i;
      size_t nameWords = (e.name.size() + 4) / 4;
      for (size_t w = 3 + nameWords; w < ep.size(); ++w) e.interface.push_back(ep.word(w));
      auto f = functionIndex_.find(e.function);
      if (f == functionIndex_.end()) return makeError("entry point '" + e.name + "' has no function body");
      e.functionIndex = f->second;
      scan_.entryPoints.push_back(std::move(e));
    }
    if (scan_.entryPoints.empty()) return makeError("module has no entry points: nothing to instrument");

    // Which entry points reach each function.
    std::vector<std::set<uint32_t>> reachedBy(module_.functions.size());
    for (uint32_t e = 0; e < scan_.entryPoints.size(); ++e) {
      std::vector<int> work = {scan_.entryPoints[e].functionIndex};
      while (!work.empty()) {
        int f = work.back();
        work.pop_back();
        if (!reachedBy[f].insert(e).second) continue;
        for (const auto& inst : module_.functions[f].insts) {
          if (inst.opcode() != spv::Op::OpFunctionCall) continue;
          auto callee = functionIndex_.find(inst.word(3));
          if (callee != functionIndex_.end()) work.push_back(callee->second);
        }
      }
    }

    for (uint32_t e = 0; e < scan_.entryPoints.size(); ++e) addEntrySites(e);
    for (size_t f = 0; f < module_.functions.size(); ++f) {
      if (reachedBy[f].empty()) continue;
      size_t before = scan_.sites.size();
      scanFunction(static_cast<int>(f), *reachedBy[f].begin());
      if (reachedBy[f].size() > 1 && scan_.sites.size() > before && scan_.needsInline.empty()) {
        scan_.needsInline = "function %" + std::to_string(module_.functions[f].id()) +
                            " with access sites is reached by several entry points";
      }
    }
    addOutputSites();
    placeVertexInputSites();
    return std::move(scan_);
  }

 private:
  void addEntrySites(uint32_t e) {
    const EntryPoint& ep = scan_.entryPoints[e];
    FoundSite s;
    s.site.kind = SiteKind::Invocation;
    s.site.stage = ep.stage;
    s.site.entryPoint = ep.name;
    s.site.opcode = "OpFunction";
    s.function = ep.functionIndex;
    s.placement = Placement::EntryStart;
    s.entryIndex = e;
    scan_.sites.push_back(std::move(s));
    if (ep.stage == Stage::Vertex) addVertexInputSites(e);
  }

  // Vertex attributes are fetched from vertex buffers once per vertex
  // invocation, whatever the shader does with them: one buffer_read per
  // input Location, counted on entry. (Index-buffer reads are not visible to
  // shaders; the capture adds them from the draw's index count.)
  void addVertexInputSites(uint32_t e) {
    const EntryPoint& ep = scan_.entryPoints[e];
    for (uint32_t var : ep.interface) {
      const Instruction* v = defs_.def(var);
      if (v == nullptr || v->opcode() != spv::Op::OpVariable) continue;
      if (static_cast<spv::StorageClass>(v->word(3)) != spv::StorageClass::Input) continue;
      if (defs_.hasDecoration(var, spv::Decoration::BuiltIn)) continue;
      auto location = defs_.decorationValue(var, spv::Decoration::Location);
      if (!location) continue;
      uint32_t type = types_.pointee(v->resultType());
      FoundSite s;
      s.site.kind = SiteKind::BufferRead;
      s.site.stage = ep.stage;
      s.site.entryPoint = ep.name;
      s.site.location = *location;
      s.site.resource = "vertex_input " + defs_.name(var);
      s.site.elementType = types_.name(type);
      s.site.elementBytes = types_.byteSize(type);
      s.site.opcode = "OpFunction";
      s.function = ep.functionIndex;
      s.placement = Placement::EntryStart;
      s.entryIndex = e;
      vertexInputSites_.emplace_back(scan_.sites.size(), var);
      scan_.sites.push_back(std::move(s));
    }
  }

  // A vertex input's site is shown at the first load of the input (its line and instruction).
  void placeVertexInputSites() {
    for (const auto& [site, var] : vertexInputSites_) {
      auto load = inputLoads_.find(var);
      if (load == inputLoads_.end()) continue;
      FoundSite& s = scan_.sites[site];
      s.shownFunction = load->second.function;
      s.shownInstruction = load->second.instruction;
      s.site.file = load->second.file;
      s.site.line = load->second.line;
    }
  }

  // One output_write site per Location of each non-builtin Output variable of
  // a fragment entry point: every invocation that returns writes them all.
  void addOutputSites() {
    for (uint32_t e = 0; e < scan_.entryPoints.size(); ++e) {
      const EntryPoint& ep = scan_.entryPoints[e];
      if (ep.stage != Stage::Fragment) continue;
      for (uint32_t var : ep.interface) {
        const Instruction* v = defs_.def(var);
        if (v == nullptr || v->opcode() != spv::Op::OpVariable) continue;
        if (static_cast<spv::StorageClass>(v->word(3)) != spv::StorageClass::Output) continue;
        if (defs_.hasDecoration(var, spv::Decoration::BuiltIn)) continue;
        auto location = defs_.decorationValue(var, spv::Decoration::Location);
        if (!location) continue;
        uint32_t type = types_.pointee(v->resultType());
        uint32_t count = 1;
        uint32_t element = type;
        if (const Instruction* t = defs_.def(type); t && t->opcode() == spv::Op::OpTypeArray) {
          count = types_.arrayLength(type).value_or(1);
          element = t->word(2);
        }
        for (uint32_t i = 0; i < count; ++i) {
          FoundSite s;
          s.site.kind = SiteKind::OutputWrite;
          s.site.stage = ep.stage;
          s.site.entryPoint = ep.name;
          s.site.location = *location + i;
          s.site.resource = defs_.name(var);
          s.site.elementType = types_.name(element);
          s.site.elementBytes = types_.byteSize(element);
          s.site.opcode = "OpReturn";
          auto line = outputLines_.find(var);
          if (line != outputLines_.end()) {
            s.site.file = line->second.first;
            s.site.line = line->second.second;
          }
          if (auto store = outputStores_.find(var); store != outputStores_.end()) {
            s.shownFunction = store->second.first;
            s.shownInstruction = store->second.second;
          }
          s.function = ep.functionIndex;
          s.placement = Placement::BeforeReturns;
          s.entryIndex = e;
          scan_.sites.push_back(std::move(s));
        }
      }
    }
  }

  // NonSemantic.Shader.DebugInfo.100 (glslang -gVS): DebugLine sets the
  // position as OpLine does, DebugNoLine ends it.
  void debugLine(const Instruction& inst, std::string& file, uint32_t& line) const {
    constexpr uint32_t kDebugSource = 35, kDebugLine = 103, kDebugNoLine = 104;
    if (inst.word(4) == kDebugNoLine) {
      file.clear();
      line = 0;
      return;
    }
    if (inst.word(4) != kDebugLine || inst.size() < 7) return;
    const Instruction* source = defs_.def(inst.word(5));
    const Instruction* start = defs_.def(inst.word(6));
    if (source == nullptr || start == nullptr || start->opcode() != spv::Op::OpConstant) return;
    if (source->opcode() == spv::Op::OpExtInst && source->word(4) == kDebugSource) file = defs_.stringOf(source->word(5));
    line = start->word(3);
  }

  void scanFunction(int f, uint32_t entry) {
    const auto& insts = module_.functions[f].insts;
    std::string file;
    uint32_t line = 0;
    for (size_t i = 0; i < insts.size(); ++i) {
      const Instruction& inst = insts[i];
      spv::Op op = inst.opcode();
      if (op == spv::Op::OpLine) {
        file = defs_.stringOf(inst.word(1));
        line = inst.word(2);
        continue;
      }
      // A block keeps the position of the block before it (in module order)
      // until it sets its own. SPIR-V ends OpLine at a block's end, but
      // glslang emits a position only when it changes: the merge block of a
      // `c ? a : b` inside a call carries on the call's line without saying
      // it again, and its accesses would otherwise have no line at all.
      if (op == spv::Op::OpNoLine) {
        file.clear();
        line = 0;
        continue;
      }
      if (op == spv::Op::OpExtInst && debugInfo_ != 0 && inst.word(3) == debugInfo_) {
        debugLine(inst, file, line);
        continue;
      }
      auto add = [&](SiteKind kind, const Resource& r, uint32_t elementType, std::string typeName = {},
                     uint32_t bytes = 0) {
        FoundSite s;
        s.site.kind = kind;
        s.site.stage = scan_.entryPoints[entry].stage;
        s.site.entryPoint = scan_.entryPoints[entry].name;
        s.site.opcode = opcodeName(op);
        s.site.file = file;
        s.site.line = line;
        describe(s, r);
        if (elementType != 0) {
          s.site.elementType = types_.name(elementType);
          s.site.elementBytes = types_.byteSize(elementType);
        } else {
          s.site.elementType = std::move(typeName);
          s.site.elementBytes = bytes;
        }
        s.function = f;
        s.instruction = i;
        s.shownFunction = f;
        s.shownInstruction = i;
        s.entryIndex = entry;
        scan_.sites.push_back(std::move(s));
      };

      if (isTextureRead(op) || op == spv::Op::OpImageWrite) {
        uint32_t imageId = op == spv::Op::OpImageWrite ? inst.word(1) : inst.word(3);
        uint32_t imageType = types_.typeOf(imageId);
        SiteKind kind = op == spv::Op::OpImageWrite ? SiteKind::ImageWrite : SiteKind::TextureRead;
        if (op == spv::Op::OpImageRead && types_.isSubpassData(imageType)) kind = SiteKind::AttachmentRead;
        auto [name, bytes] = imageElement(imageType);
        add(kind, resolver_.image(imageId), 0, name, bytes);
        continue;
      }
      if (uint32_t pw = atomicPointer(op)) {
        uint32_t ptr = inst.word(pw);
        const Instruction* pd = defs_.def(ptr);
        while (pd && pd->opcode() == spv::Op::OpCopyObject) pd = defs_.def(pd->word(3));
        if (pd && pd->opcode() == spv::Op::OpImageTexelPointer) {
          auto [name, bytes] = imageElement(resolverImageOfTexelPointer(pd));
          add(SiteKind::ImageAtomic, resolver_.pointer(ptr), 0, name, bytes);
        } else if (isBufferClass(types_.storageClassOfValue(ptr))) {
          SiteKind kind = op == spv::Op::OpAtomicLoad ? SiteKind::BufferRead : SiteKind::BufferWrite;
          add(kind, resolver_.pointer(ptr), types_.pointee(types_.typeOf(ptr)));
        }
        continue;
      }
      if (op == spv::Op::OpLoad) {
        uint32_t ptr = inst.word(3);
        const auto sc = types_.storageClassOfValue(ptr);
        if (isBufferClass(sc)) add(SiteKind::BufferRead, resolver_.pointer(ptr), inst.resultType());
        if (sc == spv::StorageClass::Input) {
          if (uint32_t var = resolver_.baseVariable(ptr); var != 0) inputLoads_.try_emplace(var, Shown{f, i, file, line});
        }
        continue;
      }
      if (op == spv::Op::OpStore) {
        uint32_t ptr = inst.word(1);
        auto sc = types_.storageClassOfValue(ptr);
        if (isBufferClass(sc)) {
          add(SiteKind::BufferWrite, resolver_.pointer(ptr), types_.pointee(types_.typeOf(ptr)));
        } else if (sc == spv::StorageClass::Output) {
          uint32_t var = resolver_.baseVariable(ptr);
          if (var != 0 && line != 0 && !outputLines_.count(var)) outputLines_[var] = {file, line};
          if (var != 0) outputStores_.try_emplace(var, f, i);
        }
        continue;
      }
      if (op == spv::Op::OpCopyMemory || op == spv::Op::OpCopyMemorySized) {
        uint32_t target = inst.word(1), source = inst.word(2);
        if (isBufferClass(types_.storageClassOfValue(source))) {
          add(SiteKind::BufferRead, resolver_.pointer(source), types_.pointee(types_.typeOf(source)));
        }
        if (isBufferClass(types_.storageClassOfValue(target))) {
          add(SiteKind::BufferWrite, resolver_.pointer(target), types_.pointee(types_.typeOf(target)));
        }
        continue;
      }
    }
  }

  uint32_t resolverImageOfTexelPointer(const Instruction* texelPointer) const {
    // OpImageTexelPointer's image operand is a pointer to the image variable (or an element).
    return types_.pointee(types_.typeOf(texelPointer->word(3)));
  }

  std::pair<std::string, uint32_t> imageElement(uint32_t typeId) const {
    const Instruction* t = defs_.def(types_.imageType(typeId));
    if (t == nullptr) return {"texel", 0};
    auto format = static_cast<spv::ImageFormat>(t->word(8));
    if (format == spv::ImageFormat::Unknown) return {"texel<" + types_.name(t->word(2)) + "> (bound view format)", 0};
    return {imageFormatName(format), imageFormatBytes(format)};
  }

  void describe(FoundSite& s, const Resource& r) {
    switch (r.kind) {
      case Resource::Kind::Descriptor:
        s.site.set = r.set;
        s.site.binding = r.binding;
        s.site.resource = defs_.name(r.variable);
        if (s.site.resource.empty()) {
          // Anonymous block instance: name it by its block type.
          const Instruction* var = defs_.def(r.variable);
          uint32_t type = types_.pointee(var->resultType());
          if (const Instruction* t = defs_.def(type); t && (t->opcode() == spv::Op::OpTypeArray ||
                                                           t->opcode() == spv::Op::OpTypeRuntimeArray)) {
            type = t->word(2);
          }
          s.site.resource = defs_.name(type);
        }
        s.site.index = r.constIndex;
        if (r.dynamicIndex != 0) {
          s.site.dynamicIndex = true;
          s.dynamicIndex = r.dynamicIndex;
          s.arrayLength = r.arrayLength;
        }
        break;
      case Resource::Kind::Physical:
        s.site.resource = "physical_storage_buffer";
        s.address = r.address;
        break;
      case Resource::Kind::Unknown:
        s.site.resource = "unresolved";
        if (!r.needsInline) scan_.notes.push_back("unresolved " + std::string(toString(s.site.kind)) + ": " + r.reason);
        break;
    }
    if (r.needsInline && scan_.needsInline.empty()) scan_.needsInline = r.reason;
  }

  const Module& module_;
  const DefIndex& defs_;
  const Types& types_;
  Resolver resolver_;
  std::unordered_map<uint32_t, int> functionIndex_;
  std::map<uint32_t, std::pair<std::string, uint32_t>> outputLines_;
  std::map<uint32_t, std::pair<int, size_t>> outputStores_;
  uint32_t debugInfo_ = 0;  // the NonSemantic.Shader.DebugInfo.100 import, 0 if none
  struct Shown {
    int function = -1;
    size_t instruction = 0;
    std::string file;
    uint32_t line = 0;
  };
  std::map<uint32_t, Shown> inputLoads_;                       // Input variable -> its first load
  std::vector<std::pair<size_t, uint32_t>> vertexInputSites_;  // (site, Input variable)  // output variable -> its first store (function, index)
  SiteScan scan_;
};

}  // namespace

Result<SiteScan> findSites(const Module& module, const DefIndex& defs, const Types& types) {
  return Scanner(module, defs, types).run();
}

}  // namespace tally::spirv
