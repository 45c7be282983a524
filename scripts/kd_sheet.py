"""kd against the truth at one val view: the truth, then each run's kd (rendered by
`fipt eval SRC RUN --cameras-from SRC`) after its least-squares scale, and below each the mean
absolute error x 4. Usage: python3 scripts/kd_sheet.py SRC VIEW OUT.png RUN [RUN ...]"""
import OpenEXR, Imath, numpy as np, sys, os
from PIL import Image
def rd(p):
    f=OpenEXR.InputFile(p); dw=f.header()['dataWindow']; w=dw.max.x-dw.min.x+1; h=dw.max.y-dw.min.y+1
    ch=[np.frombuffer(f.channel(c,Imath.PixelType(Imath.PixelType.FLOAT)),np.float32).reshape(h,w) for c in 'RGB']
    return np.stack(ch,-1)
def gt(src,v):
    d=src+'/val/DiffCol'; fs=sorted(os.listdir(d)); return rd(d+'/'+fs[v])
src,v,out=sys.argv[1],int(sys.argv[2]),sys.argv[3]; runs=sys.argv[4:]
tiles=[gt(src,v)]
for r in runs:
    k=rd(f'{r}/eval/cameras-from/views/val/{v:03d}_kd.exr'); tiles.append(k)
# scale each run's kd by least squares to gt (as eval fits)
g=tiles[0]
for i in range(1,len(tiles)):
    s=(tiles[i]*g).sum()/max((tiles[i]**2).sum(),1e-9); tiles[i]=tiles[i]*s
err=[np.abs(t-g).mean(-1,keepdims=True).repeat(3,-1)*4 for t in tiles[1:]]
row1=np.concatenate(tiles,1); row2=np.concatenate([np.zeros_like(g)]+err,1)
img=np.clip(np.concatenate([row1,row2],0),0,1)**(1/2.2)
Image.fromarray((img*255).astype(np.uint8)).resize((img.shape[1]*2,img.shape[0]*2),Image.NEAREST).save(out)
